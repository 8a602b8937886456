"""The result of a diagnosis: :class:`Diagnosis`, its JSON (:meth:`Diagnosis.to_dict`,
the keys of ``dpdfit diagnose --json``) and its text report (:meth:`Diagnosis.report`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from dpdfit.analyses.diagnosis.decisions.alternatives import alternatives_sentence
from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.analyses.diagnosis.fitting.fit_result import FitResult
from dpdfit.analyses.diagnosis.proposal.schedule import proposal_schedule
from dpdfit.analyses.diagnosis.evidence.thresholds import ALPHA
from dpdfit.core.display import Displayable

__all__ = ["CONVENTIONS", "Diagnosis", "next_measurement_sentence"]

#: what the JSON's quantities mean
CONVENTIONS = {"delta_bic": "BIC(effect) - BIC(baseline); negative favours the effect "
                            "(for an added effect: against the named ones before it)",
               "p_value": "likelihood-ratio test against the baseline "
                          "(Wilks, chi2 with the effect's parameter count)",
               "params_err": "1 sigma, Gauss-Newton (J^T J)^-1, calibration modes profiled "
                             "out; NaN at a bound or for a form's fixed parameter",
               "sizes": "the effect's size in a laboratory's terms; error (1 sigma) = "
                        "sqrt(tempering x error_statistical^2 + error_form^2): the delta-"
                        "method error (profile likelihood where a parameter sits at a "
                        "bound) inflated by the dispersion of the effect's evidence, and the "
                        "spread over its family's forms weighted by their tempered evidence",
               "delta_bic_tempered": "delta BIC with the chi2 difference divided by the "
                                     "dispersion of the evidence (tempering, >= 1) that the "
                                     "residuals show; decisions use it",
               "alternatives": "hypotheses the tempered evidence does not separate from "
                               "the named ones: delta_bic (raw) and delta_bic_tempered are "
                               "theirs minus the named hypothesis's",
               "next_measurement": "the single recording from the menu with the largest "
                                   "expected delta BIC between the hypotheses in reach per "
                                   "lab hour (Asimov, parameters held at their fits)",
               "fidelity_cost": "mean over the recorded gate settings of the Bell fidelity "
                                "without the effect minus with it (gate side: (F_pop + C)/2 "
                                "predicted; tone side: the spectral estimate F_est)",
               "significance_sigma": "two-sided Gaussian equivalent of the "
                                     "Bonferroni-corrected p-value"}


def _chosen_dict(f: FitResult) -> dict:
    single = len(f.effects) == 1
    return {"effect": f.effect, "forms": list(f.forms),
            "params": f.params_of(f.effect) if single else f.params,
            "params_err": f.errors_of(f.effect) if single else f.params_err,
            "chi2": f.chi2, "dof": f.dof, "p_fit": f.p_fit}


@dataclass(frozen=True, repr=False)
class Diagnosis(Displayable):
    """Result of :func:`~dpdfit.analyses.diagnosis.diagnose.diagnose` (JSON keys of
    ``dpdfit diagnose --json``).

    ``verdict`` is the first named effect, ``"none"`` or ``"unexplained"``;
    ``effects`` lists every named effect, best first, each with its form,
    parameters, sizes in a laboratory's terms and cost in Bell fidelity;
    ``steps`` the candidates tried as an addition at each step.
    """

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
    #: every named effect, best first (dicts: effect, form, params, sizes, fidelity_cost)
    effects: list = field(default_factory=list)
    #: ranking entries of the effects tried as additions, per step
    steps: list = field(default_factory=list)
    #: reduced chi2 per observable with the first named effect alone
    redchi_one: dict | None = None
    #: residual series (``Problem.series``) of the baseline and the chosen fit, for plots;
    #: the baseline's are taken when the baseline is fitted (the fit behind
    #: ``redchi_before``, before any effect's fit can re-choose the phase-sign convention)
    series_before: list = field(default_factory=list, repr=False)
    series_after: list = field(default_factory=list, repr=False)
    #: the problem the diagnosis solved (its forward models; not serialised)
    context: object = field(default=None, repr=False, compare=False)

    @property
    def named(self) -> list:
        """Names of the named effects, best first."""
        return [e["effect"] for e in self.effects]

    def to_dict(self) -> dict:
        return {"campaign": self.campaign, "verdict": self.verdict,
                "effects": self.effects,
                "mismatches": self.mismatches, "ranking": self.ranking,
                "redchi_before": self.redchi_before, "redchi_one": self.redchi_one,
                "redchi_after": self.redchi_after,
                "baseline_chi2": self.baseline.chi2, "baseline_dof": self.baseline.dof,
                "baseline_p_value": self.baseline_p_value,
                "baseline_nuisances": self.baseline.nuisances,
                "chosen": None if self.chosen is None else _chosen_dict(self.chosen),
                "steps": self.steps,
                "units": {e.key(p.name): p.unit for e in EFFECTS.values()
                          for p in e.parameters()},
                "conventions": dict(CONVENTIONS),
                "alpha": ALPHA, "seconds": self.seconds, **self.extra}

    def schedule(self, campaign=None) -> pd.DataFrame:
        """The proposed recording (``next_measurement``) as a schedule: one row per point
        and repeat, the table ``dpdfit diagnose --schedule`` writes
        (:func:`~dpdfit.analyses.diagnosis.proposal.schedule.proposal_schedule`).
        ``campaign``: the campaign folder the diagnosis read (default: :attr:`campaign`),
        whose grids, phases and times the recording repeats."""
        return proposal_schedule((self.extra or {}).get("next_measurement"),
                                 self.campaign if campaign is None else campaign)

    def to_frame(self) -> pd.DataFrame:
        """The ranking of the hypotheses, one row per effect (best first)."""
        return pd.DataFrame(list(self.ranking))

    def sizes_frame(self) -> pd.DataFrame:
        """The named effects' sizes, one row per (effect, quantity)."""
        rows = [{"effect": e["effect"], "quantity": k, **v}
                for e in self.effects for k, v in e["sizes"].items()]
        return pd.DataFrame(rows, columns=["effect", "quantity", "value", "error", "unit",
                                           "meaning"])

    def _display_rows(self) -> list[tuple]:
        return ([("verdict", self.verdict, None, ""),
                 ("effects", ", ".join(self.named) or "-", None, ""),
                 ("baseline p-value", self.baseline_p_value, None, "")]
                + [(f"rank {i + 1}: {r['effect']}", r["delta_bic"], None, "delta BIC")
                   for i, r in enumerate(self.ranking[:5])])

    def report(self) -> str:
        ex = self.extra or {}
        lines = [f"Diagnosis of {self.campaign}",
                 f"  baseline chi2 = {self.baseline.chi2:.1f} for {self.baseline.dof} dof "
                 f"(p = {self.baseline_p_value:.2g})",
                 f"  verdict: {self.verdict}"
                 + (f"   (named: {', '.join(self.named)})" if len(self.named) > 1 else "")]
        lines += [f"  {x}" for x in alternatives_sentence(self.verdict,
                                                           ex.get("alternatives") or [])]
        if ex.get("null_range") is not None:
            lines.append(f"  the baseline's global chi2 is above its dof, but nothing is "
                         f"located and every observable's reduced chi2 is at most "
                         f"{ex['null_range']:g} (the harness's null range): nothing missing")
        nxt = ex.get("next_measurement")
        if nxt:
            lines.append("  " + next_measurement_sentence(nxt))
        lines += ["", "  mismatches located:"]
        lines += _mismatch_lines(self.mismatches)
        lines += ["", "  ranking of single effects (delta_bic, LRT p):"]
        lines += _ranking_lines(self.ranking)
        for i, step in enumerate(self.steps):
            lines += ["", f"  added to the named effects, step {i + 1} (delta_bic vs them):"]
            lines += _ranking_lines(step[:4])
        if self.effects:
            lines += ["", "  named effects (size in a laboratory's terms, 1 sigma):"]
            for e in self.effects:
                cost = e["fidelity_cost"]
                lines.append(f"    {e['effect']} (form {e['form']}): cost in Bell fidelity "
                             f"{_pm(cost, e['fidelity_cost_err'])}")
                for k, s in e["sizes"].items():
                    parts = ("" if "error_statistical" not in s else
                             f"   (statistical {_pm(s['error_statistical'], None)} x "
                             f"sqrt({s['tempering']:.3g}) for the misfit, form "
                             f"{_pm(s['error_form'], None)})")
                    lines.append(f"      {k:>24s} = {_pm(s['value'], s['error'])} "
                                 f"{s['unit']}{parts}")
        lines += _redchi_lines(self)
        if len(self.effects) > 1:
            lines += ["", "  what each effect explains (chi2 removed per observable group):"]
            lines += _explains_lines(self)
        if ex.get("verdict_fit") == "approximate":
            lines += ["", f"  the named effects' forms are approximate: they remove "
                          f"{ex['explained_fraction']:.1%} of the baseline's excess chi2 but "
                          "leave an unacceptable fit"]
        if ex.get("generic"):
            lines += ["", "  generic smooth discrepancy where the model fails:"]
            lines += _generic_lines(ex["generic"])
        if ex.get("null_model"):
            lines += ["", "  null model (learnt from the campaign before any effect):"]
            lines += _null_model_lines(ex["null_model"])
        if ex.get("left_out"):
            lines += ["", "  left out (absent from the folder):"]
            lines += [f"    {x}" for x in ex["left_out"]]
        return "\n".join(lines)


def next_measurement_sentence(nxt: dict) -> str:
    """One sentence: the recording that would decide, or why none could be proposed."""
    if not nxt.get("what"):
        return f"no further measurement could be proposed: {nxt.get('reason', 'unknown')}"
    if nxt.get("decisive") is False and nxt.get("reason"):
        return f"no single recording would decide: {nxt['reason']}"
    st = nxt.get("settings") or {}
    how = ", ".join(f"{k} = {v if not isinstance(v, list) else ', '.join(map(str, v))}"
                    for k, v in st.items())
    mins = nxt.get("lab_seconds")
    when = "" if mins is None else f", about {mins / 60:.0f} min of lab time"
    return (f"the measurement that would decide: {nxt['what'].replace('_', ' ')} ({how}"
            f"{when}), expected delta BIC {nxt.get('expected_delta_bic', float('nan')):.3g} "
            f"between {' and '.join(nxt.get('separates') or [])}")


def _redchi_lines(d: Diagnosis) -> list:
    """Reduced chi2 per observable: baseline, then with the first effect and the final fit
    where an effect was named (without one there is no such column to print, not a nan)."""
    cols = [("baseline", d.redchi_before)]
    if d.redchi_one is not None:
        cols.append(("first effect", d.redchi_one))
    if d.redchi_after and (d.redchi_one is not None or d.redchi_after != d.redchi_before):
        cols.append(("final", d.redchi_after))
    head = " -> ".join(name for name, _ in cols) + (
        "" if d.redchi_one is not None else "; no effect named")
    lines = ["", f"  reduced chi2 per observable ({head}):"]
    for k in d.redchi_before:
        vals = [c.get(k) for _, c in cols]
        lines.append(f"    {k:>28s} " + " -> ".join(
            "     n/a" if v is None or not np.isfinite(v) else f"{v:8.2f}" for v in vals))
    return lines


def _pm(v, e) -> str:
    if v is None or not np.isfinite(v):
        return "n/a"
    return f"{v:.4g}" + ("" if e is None or not np.isfinite(e) else f" +/- {e:.2g}")


def _explains_lines(d: Diagnosis) -> list:
    """Chi2 each named effect removes, by observable group, in the order it was named."""
    return [f"    {e['effect']:>26s}: " + ", ".join(f"{g} {v:10.1f}"
                                                  for g, v in e["explains"].items())
            for e in d.effects if e.get("explains")]


def _mismatch_lines(mismatches: list) -> list:
    if not mismatches:
        return ["    none"]
    return [f"    {m['observable']:>22s} {m['sideband']:>5s} dpd={m['dpd']!s:>4} "
            f"{m['x']}=[{m['range'][0]:.4g}, {m['range'][1]:.4g}] "
            f"{m['significance_sigma']:.1f} sigma, {m['shape']}" for m in mismatches[:12]]


def _ranking_lines(ranking: list) -> list:
    lines = []
    for r in ranking[:8]:
        par = ", ".join(f"{k}={v:.4g}+/-{r['params_err'].get(k, float('nan')):.2g}"
                        for k, v in r["params"].items()
                        if np.isfinite(r["params_err"].get(k, np.nan)))
        form = f" [{r['variant']}]" if r.get("variant") else ""
        lines.append(f"    {r['effect'] + form:>44s} {r['delta_bic']:10.1f} "
                     f"{r['p_value']:9.2g}  {par}")
    return lines


def _generic_lines(g: dict) -> list:
    frac = g.get("fraction_of_excess")
    lines = [f"    {g['form']}: removes chi2 {g['chi2_removed']:.1f} with {g['dof_used']} "
             f"dof" + ("" if frac is None else f" ({frac:.1%} of the excess chi2)")]
    for r in g["series"][:10]:
        lines.append(f"    {r['observable']:>22s} {r['sideband']:>5s} dpd={r['dpd']!s:>4} "
                     f"{r['x']}=[{r['range'][0]:.4g}, {r['range'][1]:.4g}]: chi2 "
                     f"{r['chi2_before']:.1f} -> {r['chi2_after']:.1f} ({r['n_points']} "
                     f"points, {r['dof_used']} dof)")
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
