"""An effect defined outside the package, to show that registering one is all it takes.

``seventh_order_pm``: a phase distortion ``exp(i phi7 r^6)`` after the AOM
(``r = |y|/y(1)``), a higher order than the catalog's AM-to-PM (``r^2``).  Its
module is this file: the effect the diagnosis fits (``EFFECT``) and its injection
into the simulator (``INJECTION``); nothing else in dpdfit knows it.
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.effects import Effect, Param
from dpdfit.simulation.injections import Injection


class SeventhOrderPM(Effect):
    name = "seventh_order_pm"
    side = "tones"
    meaning = "phase distortion ~ |y|^6 after the AOM"
    params = (Param("phi7", "rad", -1.0, 1.0, 0.0, 0.01, "phase at full drive"),)
    main = "phi7"

    def transfer(self, tm, v, y, cy):
        r2 = (np.abs(y) / np.polynomial.polynomial.polyval(1.0, cy)) ** 2
        return y * np.exp(1j * v.get("phi7", 0.0) * r2 ** 3)

    def size_values(self, ctx, p):
        return {"phi7": ((self.values(p) or {}).get("phi7", 0.0), "rad",
                         "phase ~ |y|^6 at full drive")}


EFFECT = SeventhOrderPM()


class SeventhOrderPMInjection(Injection):
    effect = EFFECT
    harness = {"phi7": (0.08, 0.12, True)}

    def inject_field(self, v, y, x, fs, y_full):
        return y * np.exp(1j * v.get("phi7", 0.0) * (np.abs(y) / y_full) ** 6)


INJECTION = SeventhOrderPMInjection()
