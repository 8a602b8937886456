"""Result of :func:`dpdfit.analyses.stability.stability`: time series, scatter, drift, envelope."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from dpdfit.core.display import Displayable

__all__ = ["StabilityResult"]


def _num(x, fmt: str) -> str:
    """``x`` formatted, or ``n/a`` where it is not available (NaN, e.g. 2 runs: no trend error)."""
    return format(x, fmt) if x is not None and np.isfinite(x) else "n/a"


@dataclass(frozen=True, repr=False)
class StabilityResult(Displayable):
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
        """Time of each run in days since the first run, in time order."""
        return np.array([r["day"] for r in self.runs])

    @property
    def values(self) -> np.ndarray:
        """Each run's value (``y(1)`` or ``phi(1)`` in rad, see ``quantity``), in time order."""
        return np.array([r["value"] for r in self.runs])

    @property
    def stderrs(self) -> np.ndarray:
        """Each run's fit error (1 sigma) of its value, in time order."""
        return np.array([r["stderr"] for r in self.runs])

    @property
    def trend_per_day(self) -> float:
        """Fitted straight-line drift of the value, per day
        (:func:`~dpdfit.analyses.stability.timeseries.drift_test`)."""
        return self.drift["trend_per_day"]

    @property
    def trend_per_day_err(self) -> float:
        """1-sigma error of :attr:`trend_per_day`, per day (the excess run-to-run scatter
        included)."""
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

    def to_frame(self) -> pd.DataFrame:
        """The per-run table (one row per run, time order)."""
        return pd.DataFrame([dict(r) for r in self.runs])

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
                 f"    trend        : {_num(d['trend_per_day'], '+.3e')} +/- "
                 f"{_num(d['trend_per_day_err'], '.3e')}{unit}/day   95% CI "
                 f"[{_num(d['trend_ci95'][0], '+.3e')}, {_num(d['trend_ci95'][1], '+.3e')}]"
                 f"   p(zero trend) = {_num(d['trend_p_value'], '.3g')}",
                 f"    excess scatter s = {_num(d['excess_scatter'], '.3e')}{unit}; residual "
                 f"lag-1 autocorrelation {_num(d['residual_lag1_autocorr'], '+.2f')} "
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
