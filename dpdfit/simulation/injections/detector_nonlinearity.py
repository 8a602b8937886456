"""How the simulator injects ``detector_nonlinearity``: the calibration photodiode reads
``P (1 + k (P/p_full)^q)`` of the true power ``P``.

The truth is the relative reading error at the largest recorded power of the day's run
(the simulator's ``detector_nonlinearity_rel_max``).  The harness draws ``|k|`` of
0.05-0.15, and for the ``power`` form a reading error growing faster than ``P``
towards full scale (``q`` of 1.5-3).
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.effects.detector_nonlinearity import EFFECT

from .base import Injection

__all__ = ["DetectorNonlinearityInjection", "INJECTION"]


class DetectorNonlinearityInjection(Injection):
    """A nonlinear reading of the calibration photodiode."""

    effect = EFFECT
    harness = {"k": (0.05, 0.15, True)}
    # a reading error growing faster than P towards full scale (q = 1.5 in the
    # independent simulator's campaigns)
    harness_forms = {"power": {"k": (0.05, 0.15, True), "q": (1.5, 3.0, False)}}

    def inject_photodiode(self, v, power, p_full):
        u = np.maximum(power / p_full, 0.0)
        return power * (1 + v.get("k", 0.0) * u ** v.get("q", 1.0))

    def truth(self, v, sim_truth, ctx=None):
        # relative reading error at the largest recorded power of the day's run
        return {"k_det": float(sim_truth.get("calibration", {}).get(
            "detector_nonlinearity_rel_max", v.get("k", 0.0))), "q": v.get("q", 1.0)}


INJECTION = DetectorNonlinearityInjection()
