"""Result of :func:`dpdfit.analyses.propagation.propagate`: F_est, R10 and eta_bar draws per flag."""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from dpdfit.core.display import Displayable
from dpdfit.fits.draws import quantile_summary

__all__ = ["PropagationResult"]


@dataclass(frozen=True, repr=False)
class PropagationResult(Displayable):
    """Distribution of F_est, R10 and eta_bar per DPD flag at one amplitude."""

    A: float
    stale_days: float
    n_draws: int
    sigma_drift: float
    samples: dict            # {"dpd": {"F_est": arr, ...}, "no_dpd": {...}}
    point: dict              # point estimates (calibration fit as truth), same keys
    tau: float | None
    n_independent: float | None
    wall_time: float = float("nan")
    recalibration: dict | None = None

    def summary(self) -> dict:
        """Quantiles and point estimate of every sampled quantity, per DPD flag:
        ``{flag: {"<quantity>_<median|q16|q84|q2.5|q97.5|point>": value}}``."""
        out = {}
        for flag, d in self.samples.items():
            row = {}
            for key, arr in d.items():
                q = quantile_summary(arr)
                for qn, v in q.items():
                    row[f"{key}_{qn}"] = float(v)
                row[f"{key}_point"] = float(self.point[flag][key])
            out[flag] = row
        return out

    def to_frame(self) -> pd.DataFrame:
        """:meth:`summary` as a table, one row per DPD flag."""
        return pd.DataFrame.from_dict(self.summary(), orient="index")

    def _display_rows(self) -> list[tuple]:
        return [(f"{flag} F_est (median, 68% half-width)", r["F_est_median"],
                 (r["F_est_q84"] - r["F_est_q16"]) / 2, "") for flag, r in self.summary().items()] + [
            ("stale_days", self.stale_days, None, "d"), ("sigma_drift_y1", self.sigma_drift, None, ""),
            ("draws", self.n_draws, None, ""), ("tau", self.tau, None, "steps")]

    def to_dict(self) -> dict:
        d = self.summary()
        d.update({"tau": self.tau, "n_independent": self.n_independent, "A": self.A,
                  "stale_days": self.stale_days, "draws": self.n_draws,
                  "sigma_drift_y1": self.sigma_drift, "wall_time_s": self.wall_time})
        if self.recalibration is not None:
            d["recalibration"] = self.recalibration
        return d

    def report(self) -> str:
        s = self.summary()
        lines = [f"[[Drift propagation]]  A = {self.A:g}, calibration {self.stale_days:g} days "
                 f"old (sigma of y(1) drift {self.sigma_drift:.5f}), {self.n_draws} draws"]
        if self.tau is not None:
            lines.append(f"    posterior   : tau {self.tau:.2f} steps, "
                         f"{self.n_independent:.0f} independent samples")
        for flag in ("dpd", "no_dpd"):
            r = s[flag]
            lines.append(f"    {flag:7s} F_est median {r['F_est_median']:.6f}  68% "
                         f"[{r['F_est_q16']:.6f}, {r['F_est_q84']:.6f}]  95% "
                         f"[{r['F_est_q2.5']:.6f}, {r['F_est_q97.5']:.6f}]  (point "
                         f"{r['F_est_point']:.6f})")
            lines.append(f"            R10 median {r['R10_dB_median']:.2f} dB  68% "
                         f"[{r['R10_dB_q16']:.2f}, {r['R10_dB_q84']:.2f}]   eta_bar "
                         f"{r['eta_bar_median']:.4f} [{r['eta_bar_q16']:.4f}, "
                         f"{r['eta_bar_q84']:.4f}]")
        if self.recalibration:
            rc = self.recalibration
            days = rc["days_until"]
            if rc["delta_y1"] is None:          # the loss is never reached (e.g. --loss 1)
                lines.append(f"    recalibrate : no drift of y(1) within +/-0.2 costs "
                             f"{rc['loss']:g} in F_est at A = {rc['A']:g} with DPD")
            else:
                lines.append(f"    recalibrate : a drift of y(1) by {rc['delta_y1']:+.5f} costs "
                             f"{rc['loss']:g} in F_est at A = {rc['A']:g} with DPD; expected "
                             "after " + ("never (saturated drift smaller)" if days is None
                                         else f"{days:.2f} days"))
        return "\n".join(lines)
