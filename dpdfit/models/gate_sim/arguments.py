"""Argument checks shared by the modules of the gate engine (InputError on bad input)."""

from __future__ import annotations

import numpy as np

from dpdfit.errors import InputError

__all__ = ["check_tones", "positive", "probability", "check_times"]


def check_tones(b, c, n):
    """Tone amplitudes ``b, c`` (complex 1-D), distinct integer harmonics ``n``, equal lengths."""
    b = np.atleast_1d(np.asarray(b, dtype=complex))
    c = np.atleast_1d(np.asarray(c, dtype=complex))
    n_arr = np.atleast_1d(np.asarray(n))
    if not (b.ndim == c.ndim == n_arr.ndim == 1 and b.shape == c.shape == n_arr.shape):
        raise InputError("b, c and n must be 1-D arrays of equal length")
    if b.size == 0:
        raise InputError("need at least one tone")
    if not np.all(np.isfinite(n_arr)) or not np.all(n_arr == np.round(n_arr)):
        raise InputError(f"harmonic indices n must be integers, got {n_arr}")
    n_arr = n_arr.astype(int)
    if len(set(n_arr.tolist())) != n_arr.size:
        raise InputError(f"harmonic indices must be distinct, got {tuple(n_arr)}")
    if not (np.all(np.isfinite(b)) and np.all(np.isfinite(c))):
        raise InputError("tone amplitudes must be finite")
    return b, c, n_arr


def positive(name, value, allow_zero=False, allow_inf=False):
    """``float(value)`` if it is > 0 (or >= 0 with ``allow_zero``) and finite (or inf allowed)."""
    v = float(value)
    ok = (v >= 0 if allow_zero else v > 0) and (allow_inf or np.isfinite(v)) and not np.isnan(v)
    if not ok:
        raise InputError(f"{name} must be {'>= 0' if allow_zero else '> 0'}"
                         f"{'' if allow_inf else ' and finite'}, got {value}")
    return v


def probability(name, value):
    """``float(value)`` if it lies in [0, 1]."""
    v = float(value)
    if not 0.0 <= v <= 1.0:
        raise InputError(f"{name} must lie in [0, 1], got {value}")
    return v


def check_times(times):
    """Times [s] as a float array, all finite and >= 0."""
    t = np.asarray(times, dtype=float)
    if not np.all(np.isfinite(t)) or np.any(t < 0):
        raise InputError("times must be finite and >= 0 (s)")
    return t
