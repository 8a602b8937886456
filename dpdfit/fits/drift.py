"""Run-to-run drift of the amplitude calibration (Supplement S2).

:func:`drift_model` fits every run of a multi-run amplitude file
(:func:`~dpdfit.fits.calibration.fit_amplitude`) and takes ``y(1) = A_corr`` per run
with its standard error ``s_i``.  The *excess* scatter over the fit errors is::

    sigma_drift^2 = max(var(y1_i) - mean(s_i^2), 0)       (stationary spread),
    q = max(sum_j [(y1_{j+1} - y1_j)^2 - s_j^2 - s_{j+1}^2] / sum_j dt_j, 0)

(``q``: random-walk rate, per day, from consecutive runs in time order).  The
drift expected after ``d`` days is a random walk that saturates at the
difference of two independent draws of the stationary spread::

    sigma_drift(d)^2 = min(q d, 2 sigma_drift^2),     sigma_drift(0) = 0.

Without timestamps only the stationary part is known and
``sigma_drift(d > 0) = sqrt(2) sigma_drift`` (conservative).

Predictive true transfer function of a later day: a posterior draw ``a`` of
the calibration run, with ``y(1)`` moved by ``delta ~ N(0, sigma_drift(d)^2)``
by scaling the nonlinear part of the polynomial
(:func:`dpdfit.fits.draws.shift_y1`)::

    a_1 = 1,  a_k -> a_k * (y1 - 1 + delta) / (y1 - 1)   (k >= 2),

so the unit slope at the origin is kept and the *shape* of the compression is
kept (S2: the family of curves differs mainly in the onset of compression).

:func:`calibration_uncertainty` gathers what the propagation into ``F_est``
(:mod:`dpdfit.analyses.propagation`) needs from a multi-run table: the
posterior of the calibration run (:mod:`dpdfit.fits.posterior`), its fit (the
predistortion table) and the drift model, each run fitted once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import pandas as pd

from dpdfit.core.defaults import AMPLITUDE_ORDER
from dpdfit.core.display import Displayable
from dpdfit.errors import DpdfitError, FitError, InputError
from dpdfit.fits.calibration import AmplitudeCalibration, fit_amplitude
from dpdfit.fits.draws import read_only
from dpdfit.fits.posterior import PosteriorResult, sample_amplitude_posterior

__all__ = ["DriftModel", "drift_model", "fit_runs", "CalibrationUncertainty",
           "calibration_uncertainty"]


@dataclass(frozen=True, repr=False)
class DriftModel(Displayable):
    """Run-to-run drift of ``y(1)`` from repeated calibration runs (Supplement S2).

    Attributes
    ----------
    runs : list of str
        Run labels in time order.
    days : ndarray or None
        Run times in days since the first run (None without timestamps).
    y1, y1_stderr : ndarray
        ``A_corr`` of each run and its fit standard error.
    sigma_drift : float
        Excess stationary run-to-run scatter of ``y(1)``.
    rate_per_day : float or None
        Random-walk variance rate ``q`` (per day) from consecutive runs.
    """

    runs: list
    days: np.ndarray | None
    y1: np.ndarray
    y1_stderr: np.ndarray
    sigma_drift: float
    rate_per_day: float | None
    raw_sd: float

    def sigma(self, stale_days: float) -> float:
        """Expected drift (1 sigma) of y(1) after ``stale_days`` days."""
        d = float(stale_days)
        if d < 0:
            raise InputError(f"stale_days must be >= 0, got {d}")
        if d == 0:
            return 0.0
        cap = 2 * self.sigma_drift ** 2
        if self.rate_per_day is None:
            return math.sqrt(cap)
        return math.sqrt(min(self.rate_per_day * d, cap))

    def days_until(self, delta: float) -> float | None:
        """Staleness (days) at which sigma(d) reaches ``|delta|``; None if never."""
        d2 = float(delta) ** 2
        if d2 > 2 * self.sigma_drift ** 2:
            return None
        if self.rate_per_day is None or self.rate_per_day <= 0:
            return None if self.rate_per_day is not None else 0.0
        return d2 / self.rate_per_day

    def to_dict(self) -> dict:
        return {"n_runs": len(self.runs), "sigma_drift": self.sigma_drift,
                "rate_per_day": self.rate_per_day, "raw_sd": self.raw_sd,
                "mean_y1": float(np.mean(self.y1)),
                "mean_stderr": float(np.sqrt(np.mean(self.y1_stderr ** 2))),
                "span_days": None if self.days is None else float(self.days[-1] - self.days[0])}

    def to_frame(self) -> pd.DataFrame:
        """One row per run: ``run``, ``days`` (NaN without timestamps), ``y1``, ``y1_stderr``."""
        days = np.full(len(self.runs), np.nan) if self.days is None else self.days
        return pd.DataFrame({"run": list(self.runs), "days": days, "y1": self.y1,
                             "y1_stderr": self.y1_stderr})


def _runs_frame(runs_df: pd.DataFrame, source: str | None = None) -> pd.DataFrame:
    """Copy with ``run`` labels as strings (``"1"`` if absent) and parsed timestamps."""
    name = source or runs_df.attrs.get("source")
    for col in ("A", "power"):
        if col not in runs_df.columns:
            raise InputError("required column is missing", file=name, column=col)
    df = runs_df.copy()
    if "run" not in df.columns:
        df["run"] = "1"
    df["run"] = df["run"].astype(str)
    if "timestamp" in df.columns and not pd.api.types.is_datetime64_any_dtype(df["timestamp"]):
        ts = pd.to_datetime(df["timestamp"], errors="coerce", utc=True, format="mixed")
        bad = ts.isna().to_numpy()
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"'{df['timestamp'].iloc[i]}' is not a date/time (use ISO 8601)",
                             file=name, column="timestamp", row=i + 1)
        df["timestamp"] = ts
    return df


def _fit_run(sub: pd.DataFrame, order: int, run: str, name) -> AmplitudeCalibration:
    """Least-squares fit of one run; a failure names the file and the run."""
    err = sub["power_err"].to_numpy(float) if "power_err" in sub.columns else None
    try:
        return fit_amplitude(sub["A"].to_numpy(float), sub["power"].to_numpy(float), err, order,
                             source={"file": name, "run": run})
    except DpdfitError as exc:
        raise FitError(f"{name or 'runs'}: run '{run}': {exc}") from None


def _ordered_runs(df: pd.DataFrame):
    """Run labels in time order and their days since the first run (None without times)."""
    runs = list(dict.fromkeys(df["run"].tolist()))
    if "timestamp" in df.columns:
        t0 = df.groupby("run", sort=False)["timestamp"].min()
        runs = sorted(runs, key=lambda r: t0[r])
        days = np.array([(t0[r] - t0[runs[0]]).total_seconds() / 86400.0 for r in runs])
    else:
        days = None
    return runs, days


def _runs_of(runs_df: pd.DataFrame):
    """``(validated copy, source name, run labels in time order, days or None)``."""
    name = runs_df.attrs.get("source")
    df = _runs_frame(runs_df)
    runs, days = _ordered_runs(df)
    return df, name, runs, days


def fit_runs(runs_df: pd.DataFrame, order: int = AMPLITUDE_ORDER) -> dict:
    """Fit every run of a multi-run amplitude table: ``{run: AmplitudeCalibration}``.

    Runs in time order (first appearance without timestamps); each fit's
    ``source`` names the file (``runs_df.attrs["source"]``) and the run.  The
    result can be handed to :func:`drift_model` and
    :func:`calibration_uncertainty` (``fits=``) so that no run is fitted twice.
    """
    df, name, runs, _ = _runs_of(runs_df)
    return {r: _fit_run(df[df["run"] == r], order, r, name) for r in runs}


def _drift_from_fits(runs, days, y1, se) -> DriftModel:
    """The estimator of the module docstring from per-run ``y(1)`` and standard errors."""
    y1, se = np.array(y1), np.array(se)
    raw_var = float(np.var(y1, ddof=1))
    sigma = math.sqrt(max(raw_var - float(np.mean(se ** 2)), 0.0))
    rate = None
    if days is not None:
        dt = np.diff(days)
        if np.sum(dt) > 0:
            num = np.sum(np.diff(y1) ** 2 - se[1:] ** 2 - se[:-1] ** 2)
            rate = max(float(num / np.sum(dt)), 0.0)
    return DriftModel(runs=runs, days=None if days is None else read_only(days),
                      y1=read_only(y1), y1_stderr=read_only(se), sigma_drift=sigma,
                      rate_per_day=rate, raw_sd=math.sqrt(raw_var))


def drift_model(runs_df: pd.DataFrame, order: int = AMPLITUDE_ORDER, *,
                fits: dict | None = None) -> DriftModel:
    """Estimate the run-to-run drift of ``y(1)`` from a multi-run amplitude table.

    ``runs_df`` has columns ``run, A, power`` (+ ``power_err``, ``timestamp``);
    every run is fitted with :func:`~dpdfit.fits.calibration.fit_amplitude`
    (unless its fit is in ``fits``, e.g. from :func:`fit_runs`).  See the
    module docstring for the estimator.  Needs at least 2 runs.
    """
    df, name, runs, days = _runs_of(runs_df)
    if len(runs) < 2:
        raise InputError(f"drift model needs at least 2 calibration runs, got {len(runs)}",
                         file=name, column="run")
    fits = dict(fits or {})
    y1, se = [], []
    for r in runs:
        f = fits.get(r) or _fit_run(df[df["run"] == r], order, r, name)
        fits[r] = f
        y1.append(f.A_corr)
        se.append(f.A_corr_stderr)
    return _drift_from_fits(runs, days, y1, se)


class CalibrationUncertainty(NamedTuple):
    """Posterior of the calibration run, its fit (the LUT's) and the drift model."""

    posterior: PosteriorResult
    fit: AmplitudeCalibration
    drift: DriftModel | None


def calibration_uncertainty(runs_df: pd.DataFrame, order: int = AMPLITUDE_ORDER, run=None, *,
                            seed=None, n_walkers: int = 32, n_steps: int = 400,
                            force: bool = False, progress: bool = False,
                            fits: dict | None = None,
                            drift: DriftModel | None = None) -> CalibrationUncertainty:
    """Posterior of one run of a multi-run amplitude table and the drift of all runs.

    The latest run (or ``run``) is the calibration: its least-squares fit is
    the LUT's, its posterior (:func:`~dpdfit.fits.posterior.sample_amplitude_posterior`,
    started from that fit) the uncertainty.  All runs give the drift model
    (None with a single run).  Precomputed per-run ``fits``
    (:func:`fit_runs`) or a ``drift`` model are used as given (same numbers,
    no refit).
    """
    df, name, runs, days = _runs_of(runs_df)
    chosen = runs[-1] if run in (None, "latest") else str(run)
    if chosen not in runs:
        raise InputError(f"run '{chosen}' not found; runs present: {', '.join(runs[:20])}",
                         file=name, column="run")
    fits = dict(fits or {})
    for r in runs:
        fits[r] = fits.get(r) or _fit_run(df[df["run"] == r], order, r, name)
    sub = df[df["run"] == chosen]
    err = sub["power_err"].to_numpy(float) if "power_err" in sub.columns else None
    post = sample_amplitude_posterior(sub["A"].to_numpy(float), sub["power"].to_numpy(float),
                                      err, order, n_walkers=n_walkers, n_steps=n_steps,
                                      seed=seed, force=force, progress=progress,
                                      fit=fits[chosen])
    if drift is None and len(runs) >= 2:
        drift = _drift_from_fits(runs, days, [fits[r].A_corr for r in runs],
                                 [fits[r].A_corr_stderr for r in runs])
    return CalibrationUncertainty(post, fits[chosen], drift)
