"""Search a series of standardised residuals for intervals of significant deviation.

Building block of the discrepancy diagnosis (its "Locate" step): given
residuals ``z_i = (recorded_i - simulated_i) / sigma_i`` ordered by a control
parameter ``x`` (amplitude, gate rate, time), find the contiguous intervals
where the recordings depart from the simulation, and say how significant that
is after having looked at many intervals (and, through ``n_series``, at many
observables).

Statistic: for an interval of ``m`` consecutive points the offset statistic
``S = sum(z)/sqrt(m)`` is N(0, 1) under the null hypothesis (independent
standard-normal residuals).  The search takes the most extreme ``|S|`` over all
``n(n-1)/2`` intervals of at least ``min_points`` points; its global p-value
is bounded by Bonferroni: ``p_global = min(1, n_intervals * n_series *
p_local)`` with ``p_local = 2 (1 - Phi(|S|))``.  Bonferroni is conservative
for the strongly overlapping intervals, so the false-alarm rate stays below
the nominal level (tested).  Intervals are reported greedily, most
significant first, without overlaps, while ``p_global < alpha``.

Each reported interval carries a shape: the weighted straight-line fit of
the residuals inside it (``offset`` at the interval centre, ``slope`` per
unit of ``x``) and a label: ``"offset"`` when the slope is not significant
(``|t| < 2``), ``"growing"``/``"shrinking"`` when the deviation's magnitude
increases/decreases with ``x``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import norm

from dpdfit.core.display import Displayable
from dpdfit.core.memory import SCAN_BYTES_PER_INTERVAL, check_memory
from dpdfit.errors import InputError

__all__ = ["Deviation", "deviating_intervals"]


@dataclass(frozen=True, repr=False)
class Deviation(Displayable):
    """One interval of significant deviation.

    Attributes
    ----------
    lo, hi : float
        Range of the control parameter covered (inclusive).
    n_points : int
    statistic : float
        ``sum(z)/sqrt(m)``.
    p_global : float
        Multiple-testing corrected p-value (Bonferroni over intervals and series).
    significance_sigma : float
        Two-sided Gaussian equivalent of ``p_global``.
    offset, slope : float
        Straight-line fit of ``z`` in the interval (offset at its centre, slope per unit x).
    shape : str
        ``"offset"``, ``"growing"`` or ``"shrinking"``.
    """

    lo: float
    hi: float
    n_points: int
    statistic: float
    p_global: float
    significance_sigma: float
    offset: float
    slope: float
    shape: str

    def to_dict(self) -> dict:
        return {"range": [self.lo, self.hi], "n_points": self.n_points,
                "statistic": self.statistic, "p_global": self.p_global,
                "significance_sigma": self.significance_sigma, "offset": self.offset,
                "slope": self.slope, "shape": self.shape}


def _sigma_equivalent(p: float) -> float:
    return float(norm.isf(p / 2)) if p > 0 else float("inf")


def _shape(x, z):
    xc = x - x.mean()
    if x.size < 3 or np.all(xc == 0):
        return float(z.mean()), 0.0, "offset"
    A = np.column_stack([np.ones_like(xc), xc])
    coef, *_ = np.linalg.lstsq(A, z, rcond=None)
    cov = np.linalg.inv(A.T @ A)                # residuals are standardised: sigma = 1
    t = coef[1] / np.sqrt(cov[1, 1])
    if abs(t) < 2:
        label = "offset"
    else:
        label = "growing" if np.sign(coef[1]) == np.sign(coef[0]) else "shrinking"
    return float(coef[0]), float(coef[1]), label


def deviating_intervals(x, z, *, min_points: int = 2, alpha: float = 0.0027, n_series: int = 1,
                   max_intervals: int = 5) -> list[Deviation]:
    """Intervals where standardised residuals deviate significantly (see module doc).

    Parameters
    ----------
    x : array_like
        Control parameter (sorted internally).
    z : array_like
        Standardised residuals (recorded - simulated) / sigma.
    min_points : int
        Smallest interval length considered.
    alpha : float
        Global false-alarm level (default 0.0027: "3 sigma").
    n_series : int
        Number of series scanned in the same analysis (Bonferroni factor).
    max_intervals : int
        Report at most this many non-overlapping intervals.

    Returns
    -------
    list of Deviation, most significant first (empty: no significant deviation).
    """
    x = np.asarray(x, dtype=float)
    z = np.asarray(z, dtype=float)
    if x.shape != z.shape or x.ndim != 1:
        raise InputError("x and z must be 1-D arrays of equal length")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(z))):
        raise InputError("x and z must be finite")
    if min_points < 1 or n_series < 1 or not 0 < alpha < 1:
        raise InputError("need min_points >= 1, n_series >= 1 and 0 < alpha < 1")
    order = np.argsort(x, kind="stable")
    x, z = x[order], z[order]
    n = x.size
    if n < min_points:
        return []
    # the intervals [i, j) with j - i >= k = min_points: (n + 1 - k)(n + 2 - k)/2 of them
    check_memory((n + 1 - min_points) * (n + 2 - min_points) / 2 * SCAN_BYTES_PER_INTERVAL,
                 f"the deviation search of a residual series of {n} points",
                 hint="record fewer points per series or set DPDFIT_MAX_MEMORY_GB")
    c = np.concatenate([[0.0], np.cumsum(z)])
    i, j = np.triu_indices(n + 1, k=min_points)          # interval [i, j) with j - i >= min_points
    m = (j - i).astype(float)
    S = (c[j] - c[i]) / np.sqrt(m)
    n_int = S.size
    p_local = 2 * norm.sf(np.abs(S))
    p_glob = np.minimum(1.0, p_local * n_int * n_series)
    out: list[Deviation] = []
    used = np.zeros(n, dtype=bool)
    for k in np.argsort(p_glob, kind="stable"):
        if p_glob[k] >= alpha or len(out) >= max_intervals:
            break
        a, b = i[k], j[k]
        if used[a:b].any():
            continue
        used[a:b] = True
        off, slope, label = _shape(x[a:b], z[a:b])
        sig = _sigma_equivalent(float(p_glob[k]))
        if not np.isfinite(sig):
            # p underflows: large-|S| asymptotics of the Bonferroni correction,
            # |S|^2 - 2 ln(n_intervals n_series) (Gaussian tail exp(-z^2/2))
            sig = float(np.sqrt(max(S[k] ** 2 - 2 * np.log(n_int * n_series), 0.0)))
        out.append(Deviation(lo=float(x[a]), hi=float(x[b - 1]), n_points=int(b - a),
                             statistic=float(S[k]), p_global=float(p_glob[k]),
                             significance_sigma=sig,
                             offset=off, slope=slope, shape=label))
    return out
