"""Noise of recorded tone powers, learnt from the campaign itself.

A lab's ``spectra.csv`` need not say how noisy its tone powers are.  Two
things set that noise, and both are estimated here from the recordings,
before any effect is considered:

* **The noise floor** of the spectrum analyser (mean noise power per bin
  ``N0``).  A reading is ``|c + n|^2`` with complex Gaussian noise ``n`` of
  mean power ``N0`` (Rician power).  The intermodulation (IM) tones fall as
  ``A^6`` towards low drive (third order: ``|c| ~ k A^3``), so at the lowest
  amplitudes they *flatten* onto the floor.  :func:`estimate_noise_floor`
  fits, by maximum likelihood, one ``N0`` shared by every IM series
  (harmonic x sideband x flag) and one ``k`` per series to the IM readings
  within ``FLOOR_FIT_DB`` of the floor (where the leading power law holds),
  using no model of the AOM at all (a model that misses an effect would bias
  the floor).  Its error is the Hessian's.  With ``snr_db`` recorded the
  floor of each tone is the recorded one instead.
* **The repeatability** of a recorded tone power (dB, independent per tone)
  and the **laser-power jitter** common to the tones of one trace.
  :func:`robust_scale` estimates an extra variance from the *second
  differences along A* of a series' residuals: white noise gives
  ``Var(r[i-1] - 2 r[i] + r[i+1]) = v[i-1] + 4 v[i] + v[i+1]``, while a smooth
  misfit (a calibration mode or an effect the baseline lacks) is nearly
  cancelled, and the median of the standardised squares (equal to the
  median of chi2_1, 0.455, at the true scale) ignores the few places where
  it is not.  So the scales describe the noise, not the mismatch.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from scipy.optimize import brentq, minimize
from scipy.special import chndtr, i0e
from scipy.stats import chi2

from dpdfit.core.display import Displayable

__all__ = ["MAX_FLOOR_ERR_DB", "MIN_FLOOR_READINGS", "NoiseFloor", "estimate_noise_floor", "floor_from_snr", "robust_scale",
           "FLOOR_FIT_DB", "MEDIAN_CHI2_1"]

#: IM readings used for the floor: below this many dB above the first guess of the floor
FLOOR_FIT_DB = 20.0
#: median of chi2 with one degree of freedom
MEDIAN_CHI2_1 = float(chi2.median(1))
#: a floor estimate less certain than this (dB, 1 sigma) is reported as an upper limit
MAX_FLOOR_ERR_DB = 3.0
#: fewer usable IM readings than this: the floor is not estimated (upper limit only)
MIN_FLOOR_READINGS = 8


@dataclass(frozen=True, repr=False)
class NoiseFloor(Displayable):
    """Noise floor of the tone powers (dB re the spectra's reference).

    ``N0`` is the mean noise power per bin (linear), ``floor_db = 10 log10 N0``,
    ``floor_median_db`` the median noise power (``N0 ln 2``, the convention of
    ``snr_db``), ``floor_err_db`` its 1-sigma error, ``n_readings`` the IM
    readings it rests on, ``method`` how it was obtained.
    """

    N0: float
    floor_db: float
    floor_median_db: float
    floor_err_db: float
    n_readings: int
    method: str

    def to_dict(self) -> dict:
        return asdict(self)


def _nll_series(theta, x, A6, idx, T):
    """-lnL of each IM series: Rician powers ``x`` with signal ``k[idx] A^6`` and
    mean noise ``exp(theta[0])``, truncated to ``x < T`` (the readings were
    *selected* by that cut, so each one's density is renormalised by
    ``P(x < T)``)."""
    lN, lk = theta[0], theta[1:]
    # the optimiser's trial steps may leave the representable range (a series'
    # amplitude far above its readings): the -lnL is then inf/nan there, which
    # the optimiser rejects; the warnings would only be noise
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        N0 = np.exp(lN)
        s = np.exp(lk)[idx] * A6
        z = 2 * np.sqrt(x * s) / N0
        # 2x/N0 is non-central chi2 with 2 degrees of freedom and non-centrality 2s/N0
        norm = np.log(chndtr(2 * T / N0, 2, np.maximum(2 * s / N0, 1e-12)))
        ll = -lN - (x + s) / N0 + np.log(i0e(z)) + z - norm
    return -np.bincount(idx, ll, minlength=lk.size)


def _nll_adjusted(theta, x, A6, idx, T, h=1e-3):
    """Cox-Reid adjusted -lnL: each series' amplitude ``k`` rests on a handful of
    readings, and the plain maximum likelihood then puts the floor low by most
    of its error (the Neyman-Scott effect; measured -0.9 sigma).  Adding half
    the log of each ``k``'s observed information (diagonal: a ``k`` enters one
    series only) removes that bias (tests/analyses/diagnosis/model/test_null_model.py)."""
    g0 = _nll_series(theta, x, A6, idx, T)
    dk = np.r_[0.0, np.full(theta.size - 1, h)]
    with np.errstate(invalid="ignore"):       # inf - inf at rejected trial steps
        d2 = (_nll_series(theta + dk, x, A6, idx, T) - 2 * g0
              + _nll_series(theta - dk, x, A6, idx, T)) / h ** 2
        return float(g0.sum() + 0.5 * np.sum(np.log(np.maximum(d2, 1e-12))))


def estimate_noise_floor(P_raw: np.ndarray, A: np.ndarray, im: np.ndarray) -> NoiseFloor:
    """Noise floor from the IM tones where they flatten at low drive (see module doc).

    Parameters
    ----------
    P_raw : ndarray, shape (nA, ...)
        Recorded tone powers (dB), amplitude first; NaN where not recorded.
    A : ndarray, shape (nA,)
    im : ndarray of bool, shape ``P_raw.shape[1:]``
        Which tones are IM tones (each such tone position is one series).

    Returns
    -------
    NoiseFloor
        ``method`` is ``"estimated from the IM tones at low A"``, or ``"upper
        limit: the IM tones do not reach the floor"`` (then ``N0`` is the
        weakest reading's power, an upper limit, and ``floor_err_db`` NaN).
    """
    P_raw = np.asarray(P_raw, dtype=float)
    x_all = 10 ** (P_raw[:, im] / 10)                     # (nA, n_series)
    ok_all = np.isfinite(x_all)
    if not ok_all.any():
        raise ValueError("no IM tone readings")
    # first guess: the lowest readings of each series are noise (median = N0 ln 2)
    lowest = np.concatenate([x_all[ok_all[:, j], j][:2] for j in range(x_all.shape[1])])
    N0 = float(np.median(lowest) / np.log(2))
    T = N0 * 10 ** (FLOOR_FIT_DB / 10)
    sel = ok_all & (x_all < T)
    if sel.sum() < MIN_FLOOR_READINGS:
        lo = float(np.nanmin(x_all))
        return NoiseFloor(lo, 10 * np.log10(lo), 10 * np.log10(lo * np.log(2)), np.nan,
                          int(sel.sum()), "upper limit: the IM tones do not reach the floor")
    rows, cols = np.nonzero(sel)
    series, idx = np.unique(cols, return_inverse=True)
    x, A6 = x_all[rows, cols], np.asarray(A, float)[rows] ** 6
    k0 = np.array([max(np.median(x[idx == j] / A6[idx == j]), 1e-300)
                   for j in range(series.size)])
    th0 = np.r_[np.log(N0), np.log(k0)]
    res = minimize(_nll_adjusted, th0, args=(x, A6, idx, T), method="L-BFGS-B")
    # error of ln N0 from the observed information (central differences, profiled k)
    h = 1e-3
    H = np.empty((th0.size, th0.size))
    f = lambda t: _nll_adjusted(t, x, A6, idx, T)                     # noqa: E731
    E = np.eye(th0.size) * h
    for i in range(th0.size):
        for j in range(i, th0.size):
            H[i, j] = H[j, i] = (f(res.x + E[i] + E[j]) - f(res.x + E[i] - E[j])
                                 - f(res.x - E[i] + E[j]) + f(res.x - E[i] - E[j])) / (4 * h * h)
    try:
        var = float(np.linalg.inv(H)[0, 0])
    except np.linalg.LinAlgError:
        var = np.nan
    N0 = float(np.exp(res.x[0]))
    err = 10 / np.log(10) * np.sqrt(var) if var > 0 else np.nan
    if not err <= MAX_FLOOR_ERR_DB:
        # no reading sits on the floor: the data bound it from above only
        lo = float(np.nanmin(x_all))
        return NoiseFloor(lo, 10 * np.log10(lo), 10 * np.log10(lo * np.log(2)), np.nan,
                          int(x.size), "upper limit: the IM tones do not reach the floor")
    return NoiseFloor(N0, 10 * np.log10(N0), 10 * np.log10(N0 * np.log(2)), float(err),
                      int(x.size), "estimated from the IM tones at low A")


def floor_from_snr(P_raw: np.ndarray, snr_db: np.ndarray) -> NoiseFloor:
    """Summary of the recorded floors (``snr_db`` over the median noise power)."""
    med = P_raw - snr_db
    med = med[np.isfinite(med)]
    m = float(np.median(med))
    N0 = 10 ** (m / 10) / np.log(2)
    return NoiseFloor(N0, 10 * np.log10(N0), m, 0.0, int(med.size), "recorded (snr_db)")


def robust_scale(d2: np.ndarray, v_known: np.ndarray, k: np.ndarray,
                 upper: float = 10.0) -> float:
    """Extra variance scale from second differences (see module doc).

    Solves ``median(d2 / (v_known + k s^2)) = MEDIAN_CHI2_1`` for ``s >= 0``,
    where ``d2`` are squared second differences, ``v_known`` their variance
    from the known noise and ``k`` the multiplier of the unknown variance
    ``s^2`` (6 times the number of unknown-variance terms of each residual).
    Returns 0 when the known noise already explains the scatter.
    """
    d2, v_known, k = (np.asarray(a, dtype=float) for a in (d2, v_known, k))
    ok = np.isfinite(d2) & np.isfinite(v_known) & (k > 0)
    d2, v_known, k = d2[ok], v_known[ok], k[ok]
    if d2.size < 5:
        return float("nan")

    def g(s):
        return np.median(d2 / (v_known + k * s * s)) - MEDIAN_CHI2_1

    if g(0.0) <= 0:
        return 0.0
    if g(upper) > 0:
        return float(upper)
    return float(brentq(g, 0.0, upper, xtol=1e-6))
