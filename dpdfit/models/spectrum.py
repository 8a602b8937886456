"""Tone powers of simulated optical fields, and the spectral figures of merit.

dB reference of ``P_n``
-----------------------
``P_n`` is the power of the spectral component at ``+/-(nu + n xi0)`` of the
complex optical field envelope, in dB relative to a single tone of unit
normalised field amplitude: a component ``c exp(i 2 pi f t)`` of ``y(t)`` reads
``20 log10 |c|`` dB.  The field is in the unit-slope normalisation of the
calibration (``y = A`` for an ideal modulator), so a tone of the Cardioid(1,2)
waveform driven with peak amplitude ``A`` through an ideal modulator reads
``20 log10(A / peak)`` with ``peak = max|sum_j r_j e^{...}|``.  Recorded
heterodyne traces (:mod:`dpdfit.fits.tones`) use the analogous reference in
the trace's own units; ratios (``R10``, ``R23``, ``dP_n``) do not depend on it.

Figures of merit (main text; Supplement S4, S8)::

    R10 = P1_dB - P0_dB,   R23 = P2_dB - P3_dB,
    dP_n = P_n_dB(DPD) - P_n_dB(no DPD)  at matched A.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dpdfit.models.waveforms import Grid, ToneSet, predistort, synthesize

__all__ = ["FieldSpectrum", "field_tone_powers", "simulate_field", "r10", "r23"]

_TINY = 1e-300  # floor for log10 of an exactly-zero component


@dataclass(frozen=True)
class FieldSpectrum:
    """Complex tone amplitudes of one or a batch of simulated fields.

    Attributes
    ----------
    harmonics : tuple of int
    blue, red : ndarray of complex, shape (..., len(harmonics))
        Fourier amplitudes ``c`` of the components at ``+(nu + n xi0)`` and
        ``-(nu + n xi0)``.
    """

    harmonics: tuple
    blue: np.ndarray
    red: np.ndarray

    def P_dB(self, sideband: str) -> np.ndarray:
        """Tone powers in dB (reference: unit normalised field amplitude)."""
        c = {"blue": self.blue, "red": self.red}[sideband]
        return 10 * np.log10(np.maximum(np.abs(c) ** 2, _TINY))

    def index(self, n: int) -> int:
        """Position of harmonic ``n`` on the last axis of ``blue``/``red`` (ValueError if
        absent)."""
        return self.harmonics.index(int(n))


def field_tone_powers(field, grid: Grid, harmonics=(0, 1, 2, 3)) -> FieldSpectrum:
    """Exact tone amplitudes of a field sampled on ``grid`` (one FFT bin per tone).

    Parameters
    ----------
    field : array_like, shape (..., grid.n_samples)
        Complex optical field envelope (or real RF envelope).
    grid : Grid
        The grid the field was sampled on (every tone on a bin).
    harmonics : iterable of int
    """
    field = np.asarray(field)
    spec = np.fft.fft(field, axis=-1) / grid.n_samples
    kb, kr = grid.tone_bins(harmonics)
    return FieldSpectrum(tuple(int(h) for h in harmonics), spec[..., kb], spec[..., kr])


def simulate_field(transfer, tones: ToneSet, grid: Grid, A, dpd: bool, am_only: bool = False):
    """Waveform -> (DPD) -> AOM forward model (Eq. S11), for a batch of A.

    Returns
    -------
    rf : ndarray, shape (len(A), n_samples)
        RF envelope driving the AOM (after DPD if requested).
    field : ndarray of complex, same shape
        Optical field envelope.
    """
    w = synthesize(tones, grid, np.atleast_1d(np.asarray(A, dtype=float)))
    rf = predistort(w, transfer) if dpd else w
    return rf, transfer.forward(rf, am_only=am_only)


def r10(P_dB, harmonics=(0, 1, 2, 3)):
    """R10 = P1_dB - P0_dB along the last axis."""
    h = list(harmonics)
    P = np.asarray(P_dB)
    return P[..., h.index(1)] - P[..., h.index(0)]


def r23(P_dB, harmonics=(0, 1, 2, 3)):
    """R23 = P2_dB - P3_dB along the last axis."""
    h = list(harmonics)
    P = np.asarray(P_dB)
    return P[..., h.index(2)] - P[..., h.index(3)]
