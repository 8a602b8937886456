"""``higher_nbar``: a higher initial mean phonon number than the lab's model (gate side)."""

from __future__ import annotations

from .base import Effect, Param

__all__ = ["HIGHER_NBAR"]

HIGHER_NBAR = Effect(
    "higher_nbar", "gates",
    (Param("dnbar", "quanta", 0.0, 5.0, 0.05, 0.1),),
    "higher initial mean phonon number")
