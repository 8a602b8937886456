"""``higher_order_im``: fifth-order field distortion ``y (1 + k5 r^4)`` beyond the
calibrated transfer (IM5 and up), ``r = |y|/y(1)`` of the forward curve in use.

Prior: flat, ``|k5| <= 0.5``.  Size: ``k5``, the relative field change at full drive.
"""

from __future__ import annotations

import numpy as np

from .base import Effect, Param

__all__ = ["HigherOrderIM", "EFFECT"]


class HigherOrderIM(Effect):
    """Fifth-order field distortion ``y (1 + k5 r^4)`` beyond the calibrated
    transfer (IM5 and up)."""

    name = "higher_order_im"
    side = "tones"
    meaning = "fifth-order field distortion beyond the calibrated transfer (IM5 and up)"
    params = (Param("k5", "1", -0.5, 0.5, 0.0, 0.01, "relative field change at full drive"),)
    stage = 1
    main = "k5"

    def transfer(self, tm, v, y, cy):
        if not v.get("k5"):
            return y
        r2 = (np.abs(y) / np.polynomial.polynomial.polyval(1.0, cy)) ** 2
        return y * (1 + v["k5"] * r2 ** 2)

    def size_values(self, ctx, p):
        return {"k5": ((self.values(p) or {}).get("k5", 0.0), "1",
                       "relative field change ~ |y|^4 at full drive")}


EFFECT = HigherOrderIM()
