"""Stability of the amplitude and phase calibrations over time (Supplement S2, Figs. S2-S3).

A multi-run calibration file (``run`` and ``timestamp`` columns, one block of
points per run) is fitted run by run with :mod:`dpdfit.fits.calibration`; the
scalar tracked is ``y(1) = A_corr`` (amplitude) or ``phi(1)`` (phase, fitted on
``A_min <= A <= 1``).  :func:`stability` returns

* the time series (run, timestamp, day, value, per-run standard error);
* ``mean``, ``std`` (sample standard deviation over runs, ddof = 1),
  ``relative_std = std / |mean|``, ``n_runs``, ``span_days`` -- the numbers
  quoted in Supplement S2 (0.5655, 0.0091, 1.6 % for the amplitude);
* a drift test (straight line of the value versus time in days), see
  :func:`drift_test` for the error model;
* an Allan deviation for irregularly spaced runs, see :func:`allan_deviation`;
* the family of curves y(A) (or phi(A)) of all runs on a grid with the mean
  curve and the +/- 1 sigma envelope (Fig. S3).

Caveat (stated in the report): the drift test treats the run-to-run
deviations about the line as independent.  A slowly wandering response
(correlated over several runs) makes the trend error optimistic; the lag-1
autocorrelation of the residuals is reported so that this can be judged.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import optimize, stats

from dpdfit.fits.calibration import fit_amplitude, fit_phase
from dpdfit.errors import DpdfitError, FitError, InputError
from dpdfit.recordings.tables import list_runs, read_table

__all__ = ["StabilityResult", "stability", "drift_test", "allan_deviation",
           "plot_stability", "add_stability_command", "cmd_stability"]

_COLUMNS = {"amplitude": ("power", "power_err"), "phase": ("phase_rad", "phase_err")}
_DEFAULT_ORDER = {"amplitude": 8, "phase": 5}


# --------------------------------------------------------------------------- statistics


def _wls_line(t, y, var):
    """Weighted straight line y = a + b t; returns (a, b, cov, residuals, Q)."""
    w = 1.0 / var
    X = np.column_stack([np.ones_like(t), t])
    XtW = X.T * w
    cov = np.linalg.inv(XtW @ X)
    beta = cov @ (XtW @ y)
    r = y - X @ beta
    return beta[0], beta[1], cov, r, float(np.sum(w * r * r))


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

    def q_minus_dof(s2):
        return _wls_line(tc, y, se ** 2 + s2)[4] - dof

    if np.all(se == 0):
        s2 = float(np.sum(_wls_line(tc, y, np.ones(n))[3] ** 2) / dof)
    elif q_minus_dof(0.0) <= 0:
        s2 = 0.0
    else:
        hi = max(float(np.var(y, ddof=1)), float(np.max(se ** 2)), 1e-300)
        while q_minus_dof(hi) > 0:
            hi *= 4.0
        s2 = float(optimize.brentq(q_minus_dof, 0.0, hi, xtol=1e-14 * hi, rtol=1e-12))
    var = se ** 2 + s2
    if np.all(var == 0):                    # perfectly collinear data, no noise at all
        var = np.ones(n)
    a, b, cov, r, _ = _wls_line(tc, y, var)
    err = float(np.sqrt(cov[1, 1]))
    tq = stats.t.ppf(0.5 + level / 2, dof)
    p = float(2 * stats.t.sf(abs(b) / err, dof)) if err > 0 else (0.0 if b != 0 else 1.0)
    order = np.argsort(t, kind="stable")
    rr = r[order]
    lag1 = (float(np.sum(rr[1:] * rr[:-1]) / np.sum(rr * rr))
            if n > 2 and np.sum(rr * rr) > 0 else nan)
    out.update(trend_per_day=float(b), trend_per_day_err=err,
               trend_ci95=[float(b - tq * err), float(b + tq * err)], trend_p_value=p,
               intercept=float(a - b * t.mean()), excess_scatter=float(np.sqrt(s2)),
               residual_lag1_autocorr=lag1)
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


# --------------------------------------------------------------------------- result


@dataclass(frozen=True)
class StabilityResult:
    """Calibration stability over runs (Supplement S2).

    Attributes
    ----------
    kind : {"amplitude", "phase"}
    quantity : str
        ``"y(1) = A_corr"`` or ``"phi(1) [rad]"``.
    runs : list of dict
        ``run``, ``timestamp`` (ISO, UTC), ``day`` (since the first run),
        ``value``, ``stderr`` (fit error), ``n_points``, ``reduced_chi2``, in
        time order.
    mean, std, relative_std : float
        Mean over runs, sample standard deviation (ddof = 1), ``std/|mean|``.
    n_runs : int
    span_days : float
    drift : dict
        :func:`drift_test` output.
    allan : list of (tau_days, adev, n_pairs)
    grid, curves, mean_curve, std_curve : ndarray
        Family of curves (``n_runs x len(grid)``), its mean and sample sd.
    order, A_min : fit settings; ``source`` file name.
    """

    kind: str
    quantity: str
    runs: list
    mean: float
    std: float
    relative_std: float
    n_runs: int
    span_days: float
    drift: dict
    allan: list
    grid: np.ndarray
    curves: np.ndarray
    mean_curve: np.ndarray
    std_curve: np.ndarray
    order: int
    A_min: float
    source: str | None = None
    notes: list = field(default_factory=list)

    @property
    def days(self) -> np.ndarray:
        return np.array([r["day"] for r in self.runs])

    @property
    def values(self) -> np.ndarray:
        return np.array([r["value"] for r in self.runs])

    @property
    def stderrs(self) -> np.ndarray:
        return np.array([r["stderr"] for r in self.runs])

    @property
    def trend_per_day(self) -> float:
        return self.drift["trend_per_day"]

    @property
    def trend_per_day_err(self) -> float:
        return self.drift["trend_per_day_err"]

    def to_dict(self) -> dict:
        return {
            "kind": self.kind, "quantity": self.quantity, "source": self.source,
            "order": self.order, "A_min": self.A_min if self.kind == "phase" else None,
            "mean": self.mean, "std": self.std, "relative_std": self.relative_std,
            "n_runs": self.n_runs, "span_days": self.span_days,
            "mean_fit_stderr": float(np.mean(self.stderrs)),
            "trend_per_day": self.drift["trend_per_day"],
            "trend_per_day_err": self.drift["trend_per_day_err"],
            "trend_ci95": list(self.drift["trend_ci95"]),
            "trend_p_value": self.drift["trend_p_value"],
            "drift": dict(self.drift),
            "runs": [dict(r) for r in self.runs],
            "allan": [{"tau_days": t, "adev": a, "n_pairs": n} for t, a, n in self.allan],
            "envelope": {"A": self.grid.tolist(), "mean": self.mean_curve.tolist(),
                         "std": self.std_curve.tolist(), "curves": self.curves.tolist()},
            "notes": list(self.notes),
        }

    def report(self) -> str:
        d = self.drift
        unit = "" if self.kind == "amplitude" else " rad"
        span = (f"{self.span_days:.2f} days" if self.span_days >= 1
                else f"{self.span_days * 24:.2f} h")
        lines = [f"[[Calibration stability: {self.kind}]]  tracked {self.quantity}",
                 f"    source       : {self.source or '-'}   (K = {self.order}"
                 + (f", {self.A_min:g} <= A <= 1)" if self.kind == "phase" else ")"),
                 f"    runs         : {self.n_runs} over {span}",
                 f"    mean         : {self.mean:.6f}{unit}",
                 f"    std (ddof=1) : {self.std:.6f}{unit}   relative {100 * self.relative_std:.3f} %",
                 f"    fit error    : {np.mean(self.stderrs):.2e}{unit} (mean per-run stderr)",
                 f"    trend        : {d['trend_per_day']:+.3e} +/- {d['trend_per_day_err']:.3e}"
                 f"{unit}/day   95% CI [{d['trend_ci95'][0]:+.3e}, {d['trend_ci95'][1]:+.3e}]"
                 f"   p(zero trend) = {d['trend_p_value']:.3g}",
                 f"    excess scatter s = {d['excess_scatter']:.3e}{unit}; residual lag-1 "
                 f"autocorrelation {d['residual_lag1_autocorr']:+.2f} "
                 "(drift test assumes independent runs)"]
        if self.allan:
            lines.append("    Allan deviation (window means):  tau [days]   adev   n_pairs")
            for t, a, n in self.allan:
                lines.append(f"        {t:12.4g}  {a:10.3e}  {n:5d}")
        else:
            lines.append("    Allan deviation: not available (needs >= 2 adjacent non-empty windows)")
        for note in self.notes:
            lines.append(f"    note: {note}")
        return "\n".join(lines)


# --------------------------------------------------------------------------- main entry


def _load(df_or_path, kind: str) -> tuple[pd.DataFrame, str]:
    value_col, err_col = _COLUMNS[kind]
    if isinstance(df_or_path, pd.DataFrame):
        df = df_or_path.copy()
        name = str(df.attrs.get("source", "<DataFrame>"))
        for col in ("A", value_col):
            if col not in df.columns:
                raise InputError(f"required column is missing; columns present: "
                                 f"{list(df.columns)}", file=name, column=col)
        if len(df) == 0:
            raise InputError("table has no rows", file=name)
        df = df.reset_index(drop=True)
        for col in ("A", value_col) + ((err_col,) if err_col in df.columns else ()):
            vals = pd.to_numeric(df[col], errors="coerce").to_numpy(dtype=float)
            bad = ~np.isfinite(vals)
            if bad.any():
                raise InputError("value is not a finite number", file=name, column=col,
                                 row=int(np.flatnonzero(bad)[0]) + 1)
            df[col] = vals
        if "run" in df.columns:
            df["run"] = df["run"].astype(str)
        if "timestamp" in df.columns:
            ts = pd.to_datetime(df["timestamp"], errors="coerce", utc=True, format="mixed")
            bad = ts.isna().to_numpy()
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                raise InputError(f"'{df['timestamp'].iloc[i]}' is not a date/time (use ISO "
                                 "8601, e.g. 2026-03-01T09:30:00)", file=name,
                                 column="timestamp", row=i + 1)
            df["timestamp"] = ts
        return df, name
    name = str(df_or_path)
    df = read_table(df_or_path, ["A", value_col], [err_col, "run", "timestamp"],
                    ranges={"A": (0.0, 1.0)}, positive=[err_col])
    return df, name


def stability(df_or_path, kind: str = "amplitude", order: int | None = None,
              A_min: float = 0.1, *, grid_points: int = 201) -> StabilityResult:
    """Per-run calibration fits of a multi-run file and their stability over time.

    Parameters
    ----------
    df_or_path : path-like or pandas.DataFrame
        Multi-run calibration table with columns ``run``, ``timestamp``,
        ``A`` and ``power`` [``power_err``] (amplitude) or ``phase_rad``
        [``phase_err``] (phase).
    kind : {"amplitude", "phase"}
    order : int, optional
        Polynomial order K (default 8 for the amplitude, 5 for the phase).
    A_min : float
        Lower end of the phase fit window (phase only).

    Raises
    ------
    InputError
        Missing ``run``/``timestamp`` column, unparsable timestamps, fewer
        than 2 runs.
    FitError
        A run that cannot be fitted (e.g. too few points for the order),
        naming the run and the file.
    """
    if kind not in _COLUMNS:
        raise InputError(f"kind must be 'amplitude' or 'phase', got '{kind}'")
    K = _DEFAULT_ORDER[kind] if order is None else int(order)
    if K < 1:
        raise InputError(f"order must be >= 1, got {K}")
    if kind == "phase" and not 0 <= A_min < 1:
        raise InputError(f"phase fit window needs 0 <= A_min < 1, got A_min = {A_min}")
    df, name = _load(df_or_path, kind)
    value_col, err_col = _COLUMNS[kind]
    if "run" not in df.columns:
        raise InputError("stability needs a 'run' column labelling the calibration runs "
                         f"(columns present: {list(df.columns)})", file=name)
    if "timestamp" not in df.columns:
        raise InputError("stability needs a 'timestamp' column (ISO 8601 date/time of "
                         f"each run; columns present: {list(df.columns)})", file=name)
    labels = list_runs(df)
    if len(labels) < 2:
        raise InputError(f"stability needs >= 2 calibration runs, the file holds "
                         f"{len(labels)} ({', '.join(labels)})", file=name)

    if kind == "amplitude":
        grid = np.linspace(0.0, 1.0, grid_points)
    else:
        grid = np.linspace(A_min, 1.0, grid_points)
    recs, curves = [], []
    for lab in labels:
        sub = df[df["run"] == lab]
        A = sub["A"].to_numpy(dtype=float)
        v = sub[value_col].to_numpy(dtype=float)
        e = sub[err_col].to_numpy(dtype=float) if err_col in sub.columns else None
        ts = sub["timestamp"].min()
        src = {"file": name, "run": lab, "timestamp": ts.isoformat()}
        try:
            if kind == "amplitude":
                cal = fit_amplitude(A, v, e, K, source=src)
                val, se, curve = cal.A_corr, cal.A_corr_stderr, cal.y(grid)
            else:
                cal = fit_phase(A, v, e, K, A_min=A_min, A_max=1.0, source=src)
                val, se, curve = cal.phi_at_1, cal.phi_at_1_stderr, cal.phi(grid)
        except DpdfitError as exc:
            raise FitError(f"{name}: run '{lab}' ({len(A)} points): {exc}") from None
        recs.append({"run": lab, "timestamp": ts, "value": float(val), "stderr": float(se),
                     "n_points": int(cal.n_points), "reduced_chi2": float(cal.reduced_chi2)})
        curves.append(curve)

    order_t = sorted(range(len(recs)), key=lambda i: recs[i]["timestamp"])
    recs = [recs[i] for i in order_t]
    curves = np.array([curves[i] for i in order_t])
    t0 = recs[0]["timestamp"]
    for r in recs:
        r["day"] = (r["timestamp"] - t0).total_seconds() / 86400.0
        r["timestamp"] = r["timestamp"].isoformat()
    days = np.array([r["day"] for r in recs])
    vals = np.array([r["value"] for r in recs])
    ses = np.array([r["stderr"] for r in recs])
    mean = float(vals.mean())
    std = float(vals.std(ddof=1))
    notes = []
    drift = drift_test(days, vals, ses)
    if len(recs) < 3:
        notes.append("only 2 runs: no error on the trend")
    allan = allan_deviation(days, vals)
    if not allan:
        notes.append("Allan deviation not meaningful: no averaging time has two adjacent "
                      "non-empty windows")
    elif max(n for _, _, n in allan) < 5:
        notes.append("Allan deviation rests on fewer than 5 window pairs at every tau: "
                     "indicative only")
    fit_ratio = std / float(np.sqrt(np.mean(ses ** 2))) if np.all(ses > 0) else float("inf")
    if fit_ratio > 2:
        notes.append(f"run-to-run scatter is {fit_ratio:.1f}x the mean fit error: the "
                     "calibration varies between runs beyond its statistical error")
    return StabilityResult(
        kind=kind, quantity="y(1) = A_corr" if kind == "amplitude" else "phi(1) [rad]",
        runs=recs, mean=mean, std=std,
        relative_std=float(std / abs(mean)) if mean != 0 else float("inf"),
        n_runs=len(recs), span_days=float(days[-1] - days[0]), drift=drift, allan=allan,
        grid=grid, curves=curves, mean_curve=curves.mean(axis=0),
        std_curve=curves.std(axis=0, ddof=1), order=K, A_min=float(A_min),
        source=name, notes=notes)


# --------------------------------------------------------------------------- figures


def plot_stability(result: StabilityResult, outdir: str | os.PathLike) -> list[str]:
    """Write ``figS2_stability_<kind>.png`` and ``figS3_envelope_<kind>.png``.

    Fig. S2: per-run values with error bars versus time, mean (dashed),
    +/- 1 sigma band, fitted trend line.  Fig. S3: all runs' curves, the mean
    curve and the +/- 1 sigma envelope.  Written atomically; returns the paths.
    """
    from dpdfit.recordings.outputs import staged_outputs
    from dpdfit.report.plots import _pyplot
    plt = _pyplot()
    r = result
    outdir = Path(outdir)
    kind = r.kind
    color = "C0" if kind == "amplitude" else "purple"
    hours = r.span_days < 1
    scale = 24.0 if hours else 1.0
    x = r.days * scale
    ylab = "$y(1) = A_{corr}$" if kind == "amplitude" else "$\\phi(1)$ [rad]"
    paths = []
    with staged_outputs() as stage:
        fig, ax = plt.subplots(figsize=(5.2, 3.6), constrained_layout=True)
        ax.axhspan(r.mean - r.std, r.mean + r.std, color=color, alpha=0.18,
                   label=f"$\\pm1\\sigma$ ({r.std:.4g})")
        ax.axhline(r.mean, color=color, ls="--", lw=1.2, label=f"mean ({r.mean:.4f})")
        ax.errorbar(x, r.values, yerr=r.stderrs, fmt="o", color="k", ms=3.5, lw=1,
                    label=f"runs (n = {r.n_runs})")
        d = r.drift
        if np.isfinite(d.get("trend_per_day", np.nan)):
            tt = np.linspace(0, r.span_days, 50)
            ax.plot(tt * scale, d["intercept"] + d["trend_per_day"] * tt, color="C3", lw=1,
                    label=f"trend {d['trend_per_day'] * (1 / scale):+.2e}/"
                          f"{'h' if hours else 'day'} (p = {d['trend_p_value']:.2g})")
        ax.set_xlabel("time since first run [" + ("h" if hours else "days") + "]")
        ax.set_ylabel(ylab)
        ax.set_title(f"Fig. S2: {kind} calibration stability", fontsize=10)
        ax.legend(fontsize=7)
        path = outdir / f"figS2_stability_{kind}.png"
        fig.savefig(stage(path), dpi=130, format="png")
        plt.close(fig)
        paths.append(str(path))

        fig, ax = plt.subplots(figsize=(5.2, 3.6), constrained_layout=True)
        for c in r.curves:
            ax.plot(r.grid, c, color="0.6", lw=0.5, alpha=0.6)
        ax.fill_between(r.grid, r.mean_curve - r.std_curve, r.mean_curve + r.std_curve,
                        color=color, alpha=0.3, label="$\\pm1\\sigma$")
        ax.plot(r.grid, r.mean_curve, color=color, lw=1.6, label=f"mean of {r.n_runs} runs")
        ax.set_xlabel("RF amplitude $A$")
        ax.set_ylabel("$y(A)$" if kind == "amplitude" else "$\\phi(A)$ [rad]")
        ax.set_title(f"Fig. S3: {kind} response envelope", fontsize=10)
        ax.legend(fontsize=7)
        path = outdir / f"figS3_envelope_{kind}.png"
        fig.savefig(stage(path), dpi=130, format="png")
        plt.close(fig)
        paths.append(str(path))
    return paths


# --------------------------------------------------------------------------- CLI


def _guess_kind(path) -> str:
    try:
        cols = [str(c).strip() for c in
                pd.read_csv(path, comment="#", nrows=0, skipinitialspace=True).columns]
    except Exception:  # unreadable: let stability() report it properly
        return "amplitude"
    if "phase_rad" in cols and "power" not in cols:
        return "phase"
    return "amplitude"


def cmd_stability(args) -> int:
    """``dpdfit stability``: calibration stability over runs (report or JSON)."""
    kind = args.kind or _guess_kind(args.file)
    res = stability(args.file, kind=kind, order=args.order, A_min=args.A_min)
    written = plot_stability(res, args.plot) if args.plot else []
    if args.json:
        from dpdfit.recordings.outputs import to_jsonable
        d = res.to_dict()
        if written:
            d["figures"] = written
        print(json.dumps(to_jsonable(d), indent=2))
    else:
        print(res.report())
        for p in written:
            print(f"wrote {p}", file=sys.stderr)
    return 0


def add_stability_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit stability runs.csv [--kind amplitude|phase] [--order K]
    [--phase-min-A 0.1] [--json] [--plot DIR]``.

    The registered ``func`` returns 0 and raises
    :class:`~dpdfit.errors.DpdfitError` on bad input.
    """
    s = subparsers.add_parser(
        "stability", help="stability of a multi-run calibration over time (Figs. S2, S3)",
        description="Fit every run of a multi-run calibration file and report the time "
                    "series of y(1) = A_corr or phi(1), its mean and scatter, a drift test "
                    "and the Allan deviation (Supplement S2).")
    s.add_argument("file", help="calibration CSV with run, timestamp, A, power|phase_rad columns")
    s.add_argument("--kind", choices=["amplitude", "phase"], default=None,
                   help="amplitude (default) or phase; phase is chosen automatically when "
                        "the file has phase_rad and no power column")
    s.add_argument("--order", type=int, default=None,
                   help="polynomial order K (8 amplitude, 5 phase)")
    s.add_argument("--phase-min-A", type=float, default=0.1, dest="A_min",
                   help="lower end of the phase fit window (0.1)")
    s.add_argument("--json", action="store_true", help="print the JSON instead of a report")
    s.add_argument("--plot", metavar="DIR", help="write Figs. S2 and S3 (PNG) into DIR")
    s.set_defaults(func=cmd_stability)
    return s
