"""A campaign's tone features: ratios of tone powers within one trace, debiased for
the noise in their bins (the tone side's observables,
:mod:`~dpdfit.analyses.diagnosis.observables.campaign` has the whole description)."""

from __future__ import annotations

import numpy as np

__all__ = ['SIDEBANDS', 'tone_features', 'debias_tones', 'TONE_FEATURES', 'TONE_HARMONICS', 'MIN_SNR_DB']


#: tones weaker than this above the (median) floor are not used
MIN_SNR_DB = 15.0


#: per-trace tone features: name -> (sideband-resolved, harmonics used)
TONE_FEATURES = {
    "R10": (True, (1, 0)), "R23": (True, (2, 3)), "R5lo": (True, (1, -1)),
    "R5hi": (True, (2, 4)), "gate_balance": (True, (2, 1)),
    "red_blue": (False, (1, 2)), "gate_power": (False, (1, 2)),
}


#: harmonics n of the recorded tone powers (last axis of ``Campaign.P_dB``)
TONE_HARMONICS = (-1, 0, 1, 2, 3, 4)


SIDEBANDS = ("red", "blue")


def debias_tones(P_raw: np.ndarray, N0: np.ndarray, n_repeats=1):
    """Tone powers debiased for the noise in their bin, and the noise part of their error.

    ``P_raw`` (dB) reads ``|c + n|^2`` with complex noise of mean power ``N0``
    (linear, broadcastable), so ``E P = |c|^2 + N0``; the debiased power is
    ``10 log10(P - N0)`` and its error ``(10/ln 10) sqrt(2 N0 / (P - N0))`` dB.
    ``P_raw`` may be the mean of ``n_repeats`` such readings (broadcastable; the mean
    of linear powers keeps the expectation): the error is then ``1/sqrt(n_repeats)``
    of one reading's.  Tones below ``MIN_SNR_DB`` over the *median* noise power
    ``N0 ln 2`` are not used (NaN: their reading is an upper limit).

    Returns
    -------
    (P_dB, sd_noise_dB) : arrays of the shape of ``P_raw``
    """
    N0 = np.broadcast_to(np.asarray(N0, dtype=float), P_raw.shape)
    k = np.broadcast_to(np.maximum(np.asarray(n_repeats, dtype=float), 1.0), P_raw.shape)
    with np.errstate(invalid="ignore", divide="ignore"):
        snr = P_raw - 10 * np.log10(N0 * np.log(2))
        lin = 10 ** (P_raw / 10) - N0
        ok = np.isfinite(P_raw) & (snr >= MIN_SNR_DB) & (lin > 0)
        lin = np.where(ok, lin, 1.0)
        val = np.where(ok, 10 * np.log10(lin), np.nan)
        err = np.where(ok, 10 / np.log(10) * np.sqrt(2 * N0 / (lin * k)), np.nan)
    return val, err


def tone_features(P_dB: np.ndarray, A: np.ndarray, sd_dB: np.ndarray | None = None):
    """Per-trace features of tone powers (see module doc).

    Parameters
    ----------
    P_dB : ndarray, shape (nA, 2, 2, len(TONE_HARMONICS))
    A : ndarray, shape (nA,)
    sd_dB : ndarray, optional
        Errors of ``P_dB``; the features' errors are propagated (tones independent).

    Returns
    -------
    dict name -> (value, sd) with arrays of shape (nA, 2 dpd, 2 sideband) for
    sideband-resolved features and (nA, 2 dpd, 1) otherwise (``sd`` None if not given).
    """
    def tone(n):
        return P_dB[..., TONE_HARMONICS.index(n)]

    def var(n):
        return None if sd_dB is None else sd_dB[..., TONE_HARMONICS.index(n)] ** 2

    out = {}
    for name, (per_sb, (a, b)) in TONE_FEATURES.items():
        if per_sb:
            v = tone(a) - tone(b)
            e = None if sd_dB is None else np.sqrt(var(a) + var(b))
        elif name == "red_blue":
            g = 0.5 * (tone(1) + tone(2))                       # (nA, 2, 2)
            v = (g[..., 0] - g[..., 1])[..., None]
            e = None if sd_dB is None else 0.5 * np.sqrt(var(1).sum(-1) + var(2).sum(-1))[..., None]
        else:                                                   # gate_power
            g = 0.25 * (tone(1) + tone(2)).sum(-1)
            v = (g - 20 * np.log10(np.maximum(A, 1e-300))[:, None])[..., None]
            e = None if sd_dB is None else 0.25 * np.sqrt(var(1).sum(-1) + var(2).sum(-1))[..., None]
        out[name] = (v, e)
    return out
