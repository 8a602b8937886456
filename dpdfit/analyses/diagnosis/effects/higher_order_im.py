"""``higher_order_im``: fifth-order field distortion ``y (1 + k5 r^4)`` beyond the
calibrated transfer (IM5 and up), ``r = |y|/y(1)`` of the forward curve in use."""

from __future__ import annotations

from .base import Effect, Param

__all__ = ["HIGHER_ORDER_IM"]

HIGHER_ORDER_IM = Effect(
    "higher_order_im", "tones",
    (Param("k5", "1", -0.5, 0.5, 0.0, 0.01),),
    "fifth-order field distortion beyond the calibrated transfer (IM5 and up)")
