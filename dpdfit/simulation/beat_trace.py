"""Synthetic heterodyne photodiode traces: tones around the beat note plus white noise.

Used by the tests and benchmarks of the tone extraction
(:func:`dpdfit.fits.tones.trace_tone_powers`) as a trace with known tone
amplitudes.
"""

from __future__ import annotations

import math

import numpy as np

from dpdfit.errors import InputError
from dpdfit.fits.tones.params import finite_float, format_hz

__all__ = ["simulate_beat_trace"]


def simulate_beat_trace(fs: float, n_samples: int, f_det: float, tones,
                        noise_rms: float = 0.0, rng=None) -> np.ndarray:
    """Synthetic photodiode beat trace: tones around ``f_det`` plus white noise.

    Parameters
    ----------
    fs : float
        Sample rate, Hz.
    n_samples : int
        Number of samples ``N`` (``t_j = j / fs``, ``j = 0..N-1``).
    f_det : float
        Beat-note centre, Hz.
    tones : iterable of (float, float, float)
        ``(frequency_hz, amplitude, phase_rad)`` with ``frequency_hz`` the
        signed offset from ``f_det``: the trace contains
        ``amplitude * cos(2 pi (f_det + frequency_hz) t + phase_rad)``.  E.g.
        the blue tone ``n`` is at ``+(nu + n xi0)``, the red at ``-(nu + n xi0)``.
    noise_rms : float
        Standard deviation of additive white Gaussian noise (trace units).
    rng : None, int or numpy.random.Generator
        Seed or generator for the noise.

    Returns
    -------
    ndarray, shape (N,), float64
    """
    fs = finite_float(fs, "fs")
    f_det = finite_float(f_det, "f_det")
    noise_rms = finite_float(noise_rms, "noise_rms", positive=False)
    if noise_rms < 0:
        raise InputError(f"noise_rms must be >= 0, got {noise_rms:g}")
    if int(n_samples) != n_samples or n_samples < 1:
        raise InputError(f"n_samples must be a positive integer, got {n_samples!r}")
    n = int(n_samples)
    j = np.arange(n, dtype=np.float64)
    out = np.zeros(n)
    for i, tone in enumerate(tones):
        try:
            f, amp, ph = (float(v) for v in tone)
        except (TypeError, ValueError):
            raise InputError(f"tone {i}: expected (frequency_hz, amplitude, phase_rad), "
                             f"got {tone!r}") from None
        if not all(map(math.isfinite, (f, amp, ph))):
            raise InputError(f"tone {i}: values must be finite, got {tone!r}")
        fa = f_det + f
        if not 0 < fa < fs / 2:
            raise InputError(f"tone {i}: f_det + frequency = {format_hz(fa)} is outside "
                             f"(0, fs/2 = {format_hz(fs / 2)})")
        cycles = np.mod(j * (fa / fs), 1.0)        # keep the cosine argument small
        out += amp * np.cos(2 * np.pi * cycles + ph)
    if noise_rms > 0:
        out += noise_rms * np.random.default_rng(rng).standard_normal(n)
    return out

