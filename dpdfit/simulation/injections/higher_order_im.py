"""How the simulator injects ``higher_order_im``: the field ``y (1 + k5 r^4)`` after the
AOM, ``r = |y|/y(1)``."""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.effects.higher_order_im import EFFECT

from .base import Injection

__all__ = ["HigherOrderIMInjection", "INJECTION"]


class HigherOrderIMInjection(Injection):
    """Fifth-order distortion of the simulated optical field."""

    effect = EFFECT
    harness = {"k5": (0.01, 0.03, True)}

    def inject_field(self, v, y, x, fs, y_full):
        r2 = (np.abs(y) / y_full) ** 2
        return y * (1 + v.get("k5", 0.0) * r2 ** 2)


INJECTION = HigherOrderIMInjection()
