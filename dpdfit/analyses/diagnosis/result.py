"""The result of a diagnosis: :class:`Diagnosis`, its JSON (:meth:`Diagnosis.to_dict`,
the keys of ``dpdfit diagnose --json``) and its text report (:meth:`Diagnosis.report`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.analyses.diagnosis.fitting import FitResult
from dpdfit.analyses.diagnosis.verdict import ALPHA
from dpdfit.core.display import Displayable

__all__ = ["CONVENTIONS", "Diagnosis"]

#: what the JSON's quantities mean
CONVENTIONS = {"delta_bic": "BIC(effect) - BIC(baseline); negative favours the effect",
               "p_value": "likelihood-ratio test against the baseline "
                          "(Wilks, chi2 with the effect's parameter count)",
               "params_err": "1 sigma, Gauss-Newton (J^T J)^-1",
               "significance_sigma": "two-sided Gaussian equivalent of the "
                                     "Bonferroni-corrected p-value"}


@dataclass(frozen=True, repr=False)
class Diagnosis(Displayable):
    """Result of :func:`~dpdfit.analyses.diagnosis.diagnose.diagnose` (JSON keys of
    ``dpdfit diagnose --json``)."""

    campaign: str
    mismatches: list
    ranking: list
    verdict: str
    redchi_before: dict
    redchi_after: dict
    baseline: FitResult
    chosen: FitResult | None
    baseline_p_value: float
    seconds: float
    extra: dict = field(default_factory=dict)
    #: residual series (``Problem.series``) of the baseline and the chosen fit, for plots
    series_before: list = field(default_factory=list, repr=False)
    series_after: list = field(default_factory=list, repr=False)

    def to_dict(self) -> dict:
        return {"campaign": self.campaign, "verdict": self.verdict,
                "mismatches": self.mismatches, "ranking": self.ranking,
                "redchi_before": self.redchi_before, "redchi_after": self.redchi_after,
                "baseline_chi2": self.baseline.chi2, "baseline_dof": self.baseline.dof,
                "baseline_p_value": self.baseline_p_value,
                "baseline_nuisances": self.baseline.nuisances,
                "chosen": None if self.chosen is None else {
                    "effect": self.chosen.effect, "params": self.chosen.params,
                    "params_err": self.chosen.params_err, "chi2": self.chosen.chi2,
                    "dof": self.chosen.dof, "p_fit": self.chosen.p_fit},
                "units": {p.name: p.unit for e in EFFECTS.values() for p in e.params},
                "conventions": dict(CONVENTIONS),
                "alpha": ALPHA, "seconds": self.seconds, **self.extra}

    def to_frame(self) -> pd.DataFrame:
        """The ranking of the hypotheses, one row per effect (best first)."""
        return pd.DataFrame(list(self.ranking))

    def _display_rows(self) -> list[tuple]:
        return ([("verdict", self.verdict, None, ""),
                 ("baseline p-value", self.baseline_p_value, None, "")]
                + [(f"rank {i + 1}: {r['effect']}", r["delta_bic"], None, "delta BIC")
                   for i, r in enumerate(self.ranking[:5])])

    def report(self) -> str:
        lines = [f"Diagnosis of {self.campaign}",
                 f"  baseline chi2 = {self.baseline.chi2:.1f} for {self.baseline.dof} dof "
                 f"(p = {self.baseline_p_value:.2g})",
                 f"  verdict: {self.verdict}", "", "  mismatches located:"]
        lines += _mismatch_lines(self.mismatches)
        lines += ["", "  ranking (delta_bic, LRT p):"]
        lines += _ranking_lines(self.ranking)
        lines += ["", "  reduced chi2 per observable (before -> after):"]
        for k in self.redchi_before:
            lines.append(f"    {k:>28s} {self.redchi_before[k]:8.2f} -> "
                         f"{self.redchi_after.get(k, float('nan')):8.2f}")
        ex = self.extra or {}
        if ex.get("verdict_fit") == "approximate":
            lines += ["", f"  the named effect's catalog form is approximate: it removes "
                          f"{ex['explained_fraction']:.1%} of the baseline's excess chi2 but "
                          "leaves an unacceptable fit"]
        if ex.get("null_model"):
            lines += ["", "  null model (learnt from the campaign before any effect):"]
            lines += _null_model_lines(ex["null_model"])
        if ex.get("left_out"):
            lines += ["", "  left out (absent from the folder):"]
            lines += [f"    {x}" for x in ex["left_out"]]
        return "\n".join(lines)


def _mismatch_lines(mismatches: list) -> list:
    if not mismatches:
        return ["    none"]
    return [f"    {m['observable']:>22s} {m['sideband']:>5s} dpd={m['dpd']:>2} "
            f"{m['x']}=[{m['range'][0]:.4g}, {m['range'][1]:.4g}] "
            f"{m['significance_sigma']:.1f} sigma, {m['shape']}" for m in mismatches[:12]]


def _ranking_lines(ranking: list) -> list:
    lines = []
    for r in ranking[:8]:
        par = ", ".join(f"{k}={v:.4g}+/-{r['params_err'][k]:.2g}" for k, v in
                        r["params"].items())
        lines.append(f"    {r['effect']:>40s} {r['delta_bic']:10.1f} {r['p_value']:9.2g}  "
                     f"{par}")
    return lines


def _null_model_lines(nm: dict) -> list:
    tn = nm["tone_noise"]
    fl = tn["noise_floor"]
    err = "" if not np.isfinite(fl["floor_err_db"]) else f" +/- {fl['floor_err_db']:.2f}"
    lines = [f"    noise floor {fl['floor_db']:.2f}{err} dB ({fl['method']})",
             f"    tone repeatability {tn['tone_repeatability_db']:.4f} dB, "
             f"trace power jitter {tn['trace_power_jitter_db']:.4f} dB"]
    if nm.get("rate_scatter"):
        rs = nm["rate_scatter"]
        lines.append(f"    gate-rate calibration scatter {rs['rel']:.3%} "
                     f"(stated {rs['stated_rel']:.3%})")
    if nm.get("phase_sign") is not None:
        lines.append(f"    phase-sign convention {nm['phase_sign']:+d}")
    fitted = nm.get("fitted") or {}
    if fitted:
        lines.append("    fitted: " + ", ".join(f"{k}={v:.4g}" for k, v in fitted.items()))
    return lines
