"""``gate_rate_miscalibration``: the optical power at gate time differs from the
gate-rate calibration by ``eps`` dB (gate side; its response is quadratic and
includes the lab's known per-scan jitter and gate-rate calibration error)."""

from __future__ import annotations

from .base import Effect, Param

__all__ = ["GATE_RATE_MISCALIBRATION"]

GATE_RATE_MISCALIBRATION = Effect(
    "gate_rate_miscalibration", "gates",
    (Param("eps", "dB", -3.0, 3.0, 0.0, 0.1),),
    "optical power at gate time differs from the gate-rate calibration")
