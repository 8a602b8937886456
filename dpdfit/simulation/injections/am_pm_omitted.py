"""How the simulator injects ``am_pm_omitted``: a phase growing with the drive.

Both places of the family at once, as the forms set them: ``dphi r^2`` after the
AOM (``r = |y|/y(1)``, form ``post``) and ``dphi_x |x|^2 + dphi_x4 |x|^4`` of the
RF drive amplitude in the modulator (forms ``aom``, ``aom_quartic``).  The harness
draws phases of 0.05-0.15 rad at full drive (and 0.02-0.08 rad of the quartic term).

The modulator's own part is the AOM's: a phase run taken after the recordings records
it (:meth:`~dpdfit.simulation.injections.base.Injection.inject_phase_run`; the model's
phase run, taken before, did not, which is why the model lacks it).  The part after the
AOM is the beam path's, which a phase run of the AOM does not see.
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.effects.am_pm_omitted import EFFECT

from .base import Injection

__all__ = ["AmPmOmittedInjection", "INJECTION"]


class AmPmOmittedInjection(Injection):
    """A phase ~ ``|y|^2`` after the AOM and ~ ``|x|^2``, ``|x|^4`` of its drive."""

    effect = EFFECT
    harness = {"dphi": (0.05, 0.15, True)}
    harness_forms = {"aom": {"dphi_x": (0.05, 0.15, True)},
                     "aom_quartic": {"dphi_x": (0.05, 0.15, True),
                                     "dphi_x4": (0.02, 0.08, True)}}

    def inject_field(self, v, y, x, fs, y_full):
        r2 = (np.abs(y) / y_full) ** 2
        x2 = np.minimum(np.abs(x), 1.0) ** 2
        return y * np.exp(1j * (v.get("dphi", 0.0) * r2 + v.get("dphi_x", 0.0) * x2
                                + v.get("dphi_x4", 0.0) * x2 * x2))

    def inject_phase_run(self, v, A):
        x2 = np.minimum(np.abs(np.asarray(A, dtype=float)), 1.0) ** 2
        return v.get("dphi_x", 0.0) * x2 + v.get("dphi_x4", 0.0) * x2 * x2


INJECTION = AmPmOmittedInjection()
