"""``detector_nonlinearity``: the calibration photodiode read ``P (1 + k (P/P_max)^q)``.

The true transfer is the corrected one while the table was built from the
distorted one (``q = 1``: saturation; another ``q``: a nonlinearity of
another order).
"""

from __future__ import annotations

from .base import Effect, Param

__all__ = ["DETECTOR_NONLINEARITY"]

DETECTOR_NONLINEARITY = Effect(
    "detector_nonlinearity", "tones",
    (Param("k_det", "1/P_max", -0.5, 0.5, 0.0, 0.02),
     Param("q_det", "1", 0.5, 3.0, 1.0, 0.1)),
    "calibration photodiode response P (1 + k (P/P_max)^q): saturation (q = 1) or "
    "a nonlinearity of another order")
