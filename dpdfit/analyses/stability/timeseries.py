"""Statistics of a calibration time series: straight-line drift test and Allan deviation."""

from __future__ import annotations

import numpy as np
from scipy import optimize, stats

__all__ = ["drift_test", "allan_deviation"]


def _wls_line(t, y, var):
    """Weighted straight line y = a + b t; returns (a, b, cov, residuals, Q)."""
    w = 1.0 / var
    X = np.column_stack([np.ones_like(t), t])
    XtW = X.T * w
    cov = np.linalg.inv(XtW @ X)
    beta = cov @ (XtW @ y)
    r = y - X @ beta
    return beta[0], beta[1], cov, r, float(np.sum(w * r * r))


def _excess_variance(tc, y, se, dof) -> float:
    """Paule-Mandel ``s^2``: generalised chi-square of the weighted line = ``dof``.

    ``tc``: centred times; ``se``: fit errors (all zero: plain residual variance).
    """
    def q_minus_dof(s2):
        return _wls_line(tc, y, se ** 2 + s2)[4] - dof

    if np.all(se == 0):
        return float(np.sum(_wls_line(tc, y, np.ones(y.size))[3] ** 2) / dof)
    if q_minus_dof(0.0) <= 0:
        return 0.0
    hi = max(float(np.var(y, ddof=1)), float(np.max(se ** 2)), 1e-300)
    while q_minus_dof(hi) > 0:
        hi *= 4.0
    return float(optimize.brentq(q_minus_dof, 0.0, hi, xtol=1e-14 * hi, rtol=1e-12))


def _lag1_autocorrelation(t, r) -> float:
    """Lag-1 autocorrelation of the residuals ``r`` in time order (NaN if undefined)."""
    rr = r[np.argsort(t, kind="stable")]
    if rr.size > 2 and np.sum(rr * rr) > 0:
        return float(np.sum(rr[1:] * rr[:-1]) / np.sum(rr * rr))
    return float("nan")


def drift_test(t_days, values, stderr=None, level: float = 0.95) -> dict:
    """Straight-line drift test of a calibration time series.

    Error model
    -----------
    Each run's value scatters about the line with variance ``se_i^2 + s^2``:
    ``se_i`` is the run's fit error, ``s`` an *excess* run-to-run scatter
    common to all runs (for the AOM the run-to-run variation dominates the fit
    errors (about 2x in the bundled campaign), so weights ``1/se_i^2`` alone would give a
    grossly over-confident trend).  ``s^2`` is estimated by the method of
    moments of Paule & Mandel: the value for which the generalised
    chi-square of the weighted line fit equals its degrees of freedom,
    ``sum_i (y_i - a - b t_i)^2 / (se_i^2 + s^2) = n - 2`` (``s = 0`` if the
    fit errors already explain the scatter).  When all ``se_i`` are equal this
    is exactly ordinary least squares with the residual scatter, whose slope
    t-statistic has Student's t distribution with ``n - 2`` degrees of
    freedom; that distribution is used for the confidence interval and the
    two-sided p-value for zero trend.  Compared with plain OLS it keeps a
    sensible weighting when some runs have much larger fit errors than
    others.  Without ``stderr`` it is plain OLS.

    Assumption: deviations of different runs are independent.  Correlated
    (slowly wandering) deviations make the interval too narrow; see
    ``residual_lag1_autocorr``.

    Returns
    -------
    dict with ``trend_per_day``, ``trend_per_day_err``, ``trend_ci95``
    (list of two), ``trend_p_value``, ``intercept`` (value at day 0),
    ``excess_scatter`` (``s``), ``dof``, ``residual_lag1_autocorr``,
    ``method``.  With fewer than 3 runs or zero time span the trend error,
    interval and p-value are NaN.
    """
    t = np.asarray(t_days, dtype=float)
    y = np.asarray(values, dtype=float)
    n = t.size
    se = np.zeros(n) if stderr is None else np.nan_to_num(np.asarray(stderr, dtype=float))
    nan = float("nan")
    out = {"trend_per_day": nan, "trend_per_day_err": nan, "trend_ci95": [nan, nan],
           "trend_p_value": nan, "intercept": nan, "excess_scatter": nan, "dof": n - 2,
           "residual_lag1_autocorr": nan, "level": level,
           "method": "weighted least-squares line, weights 1/(se_i^2 + s^2), s by the "
                     "Paule-Mandel method of moments; Student t with n-2 dof"}
    if n < 2 or np.ptp(t) <= 0:
        out["note"] = "trend undefined: fewer than 2 runs or all runs at the same time"
        return out
    if n == 2:
        a, b, _, _, _ = _wls_line(t, y, np.ones(n))
        out.update(trend_per_day=float(b), intercept=float(a),
                   note="two runs: the line passes through both, no error estimate")
        return out
    dof = n - 2
    tc = t - t.mean()                       # centred for conditioning
    s2 = _excess_variance(tc, y, se, dof)
    var = se ** 2 + s2
    if np.all(var == 0):                    # perfectly collinear data, no noise at all
        var = np.ones(n)
    a, b, cov, r, _ = _wls_line(tc, y, var)
    err = float(np.sqrt(cov[1, 1]))
    tq = stats.t.ppf(0.5 + level / 2, dof)
    p = float(2 * stats.t.sf(abs(b) / err, dof)) if err > 0 else (0.0 if b != 0 else 1.0)
    out.update(trend_per_day=float(b), trend_per_day_err=err,
               trend_ci95=[float(b - tq * err), float(b + tq * err)], trend_p_value=p,
               intercept=float(a - b * t.mean()), excess_scatter=float(np.sqrt(s2)),
               residual_lag1_autocorr=_lag1_autocorrelation(t, r))
    return out


def allan_deviation(t_days, values, taus=None, min_pairs: int = 1) -> list[tuple]:
    """Allan deviation of an irregularly sampled series, by window means.

    Estimator: the time axis from the first run is cut into consecutive
    windows of duration ``tau``; each non-empty window is replaced by the mean
    of its values; the Allan variance is half the mean squared difference of
    the means of *adjacent* windows that are both non-empty,
    ``AVAR(tau) = < (ybar_{k+1} - ybar_k)^2 > / 2``.  For evenly spaced data
    with one point per window this is the ordinary (non-overlapping) Allan
    variance; for irregular runs it averages however many runs fall in a
    window, so white run-to-run scatter falls as ``1/sqrt(tau)`` once ``tau``
    exceeds the typical spacing, while drift or slow wander makes it level off
    or rise.  Only ``tau`` with at least ``min_pairs`` pairs of adjacent
    non-empty windows are returned; with few pairs the value is very
    uncertain (relative error ~ ``1/sqrt(2 n_pairs)``), hence ``n_pairs``.

    Parameters
    ----------
    taus : array_like, optional
        Averaging times in days; default: from the median run spacing up to
        half the span, in factors of 2.

    Returns
    -------
    list of ``(tau_days, adev, n_pairs)``.
    """
    t = np.asarray(t_days, dtype=float)
    y = np.asarray(values, dtype=float)
    if t.size < 2 or np.ptp(t) <= 0:
        return []
    order = np.argsort(t, kind="stable")
    t, y = t[order] - t[order][0], y[order]
    if taus is None:
        gaps = np.diff(t)
        gaps = gaps[gaps > 0]
        start = float(np.median(gaps)) if gaps.size else float(np.ptp(t)) / 2
        span = float(t[-1])
        taus = []
        tau = start
        while tau <= span / 2 * (1 + 1e-12):
            taus.append(tau)
            tau *= 2
    out = []
    for tau in taus:
        tau = float(tau)
        if not tau > 0:
            continue
        k = np.floor(t / tau).astype(np.int64)
        idx, inv = np.unique(k, return_inverse=True)
        sums = np.bincount(inv, weights=y)
        counts = np.bincount(inv)
        means = sums / counts
        adjacent = np.diff(idx) == 1
        n_pairs = int(adjacent.sum())
        if n_pairs < max(int(min_pairs), 1):
            continue
        d = np.diff(means)[adjacent]
        out.append((tau, float(np.sqrt(0.5 * np.mean(d * d))), n_pairs))
    return out
