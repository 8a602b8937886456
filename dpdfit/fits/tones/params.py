"""Checks of the tone-extraction parameters and the frequency format of its messages.

Shared by the tone extraction (:mod:`dpdfit.fits.tones.extract`), its report
and the synthetic beat-trace generator
(:mod:`dpdfit.simulation.beat_trace`), so that all of them word their errors
the same way.
"""

from __future__ import annotations

import math

import numpy as np

from dpdfit.errors import InputError

__all__ = ["finite_float", "format_hz", "harmonic_numbers"]


def finite_float(value, name: str, *, positive: bool = True) -> float:
    """A finite (positive) float parameter, or InputError naming it."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise InputError(f"{name} must be finite, got {v}")
    if positive and v <= 0:
        raise InputError(f"{name} must be > 0, got {v:g}")
    return v


def format_hz(f: float) -> str:
    """Compact frequency with unit (for messages)."""
    a = abs(f)
    if a >= 1e9:
        return f"{f / 1e9:.6g} GHz"
    if a >= 1e6:
        return f"{f / 1e6:.7g} MHz"
    if a >= 1e3:
        return f"{f / 1e3:.6g} kHz"
    return f"{f:.4g} Hz"


def harmonic_numbers(values, name: str) -> tuple[int, ...]:
    """Distinct integer harmonic numbers, ascending, or InputError naming ``name``."""
    try:
        vals = list(values)
    except TypeError:
        raise InputError(f"{name} must be a sequence of integers, got {values!r}") from None
    out = []
    for v in vals:
        try:
            ok = not isinstance(v, (bool, np.bool_)) and float(v).is_integer()
        except (TypeError, ValueError, OverflowError):
            ok = False
        if not ok:
            raise InputError(f"{name}: {v!r} is not an integer harmonic number")
        out.append(int(float(v)))
    if len(set(out)) != len(out):
        raise InputError(f"{name} lists a harmonic more than once: {out}")
    return tuple(sorted(out))
