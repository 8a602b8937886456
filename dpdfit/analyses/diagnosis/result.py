"""The result of a diagnosis: :class:`Diagnosis`, typed and read-only, and its JSON
(:meth:`Diagnosis.to_dict`, the keys of ``dpdfit diagnose --json``).

Its parts are typed too: the alternatives
(:class:`~dpdfit.analyses.diagnosis.decisions.alternatives.Alternative`), the upper
limits (:class:`~dpdfit.analyses.diagnosis.decisions.upper_limits.UpperLimit`), the proposed
recording (:class:`~dpdfit.analyses.diagnosis.proposal.next_measurement.NextMeasurement`),
the null model (:class:`~dpdfit.analyses.diagnosis.model.null_model.NullModel`).  The text
report is rendered apart (:mod:`~dpdfit.analyses.diagnosis.rendering`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import pandas as pd

from dpdfit.analyses.diagnosis.comparison.compare import Comparison, compare_diagnoses
from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.analyses.diagnosis.evidence.thresholds import ALPHA, LIMIT_LEVEL, ZERO_Z
from dpdfit.analyses.diagnosis.fitting.fit_result import FitResult
from dpdfit.analyses.diagnosis.model.null_model import NullModel
from dpdfit.analyses.diagnosis.proposal.next_measurement import NextMeasurement
from dpdfit.analyses.diagnosis.proposal.schedule import proposal_schedule
from dpdfit.analyses.diagnosis.rendering import report_text
from dpdfit.core.display import Displayable

__all__ = ["CONVENTIONS", "Diagnosis"]

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
               "upper_limits": "effects the recordings do not see: an addition to the "
                               "named ones whose main size is consistent with zero "
                               f"(|value| <= {ZERO_Z:g} sigma, sigma statistical x "
                               f"sqrt(tempering)), bounded by limit = |value| + {ZERO_Z:g} "
                               f"sigma at level {LIMIT_LEVEL:g}; not among the alternatives",
               "next_measurement": "the single recording from the menu with the largest "
                                   "expected delta BIC between the named hypothesis and "
                                   "the strongest alternative per lab hour (Asimov, "
                                   "parameters held at their fits)",
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
    ``dpdfit diagnose --json``: :meth:`to_dict`).

    ``verdict`` is the first named effect, ``"none"`` or ``"unexplained"``;
    ``effects`` lists every named effect, best first, each with its form,
    parameters, sizes in a laboratory's terms and cost in Bell fidelity;
    ``steps`` the candidates tried as an addition at each step.
    """

    #: the campaign folder the diagnosis read
    campaign: str
    #: the mismatches located in the baseline's residuals, most significant first
    mismatches: list
    #: ranking entries of the single effects, best family evidence first
    ranking: list
    #: the first named effect, ``"none"`` or ``"unexplained"``
    verdict: str
    #: reduced chi2 per observable of the baseline and of the final fit
    redchi_before: dict
    redchi_after: dict
    #: the baseline's fit and the named effects' (None when nothing is named)
    baseline: FitResult
    chosen: FitResult | None
    #: the baseline's chi2 p-value
    baseline_p_value: float
    #: seconds the diagnosis took
    seconds: float
    #: every named effect, best first (dicts: effect, form, params, sizes, fidelity_cost)
    effects: list = field(default_factory=list)
    #: ranking entries of the effects tried as additions, per step
    steps: list = field(default_factory=list)
    #: reduced chi2 per observable with the first named effect alone
    redchi_one: dict | None = None
    #: which tests say the baseline does not describe the recordings (empty: none;
    #: :func:`~dpdfit.analyses.diagnosis.evidence.mismatches.mismatch_evidence`)
    mismatch_evidence: tuple = ()
    #: the named effects' fit: ``"acceptable"``, ``"approximate"`` (decisive, but its form
    #: leaves an unacceptable fit) or ``"none"``
    verdict_fit: str = "none"
    #: the hypotheses the recordings do not separate from the named one (open: rivals
    #: with support of their own)
    alternatives: tuple = ()
    #: the effects the recordings do not see, bounded: additions to the named ones whose
    #: fitted size is consistent with zero
    #: (:class:`~dpdfit.analyses.diagnosis.decisions.upper_limits.UpperLimit`)
    upper_limits: tuple = ()
    #: the recording that would decide, or why none is proposed (None: none was needed)
    proposal: NextMeasurement | None = None
    #: the null range of reduced chi2 that made a global mismatch a null (None: not used)
    null_range: float | None = None
    #: the fraction of the baseline's excess chi2 the named effects remove
    explained_fraction: float | None = None
    #: what the baseline learnt before any effect
    null_model: NullModel | None = None
    #: an earlier proposal's binding pair refitted on this campaign,
    #: ``[{"effects", "forms", "chi2"}]`` (None: not asked for)
    refits: list | None = None
    #: a smooth generic discrepancy fitted where the model fails (None: not needed)
    generic: dict | None = None
    #: seconds per stage of the diagnosis
    timing_seconds: dict = field(default_factory=dict)
    #: the nuisances of the baseline and their units
    nuisances: dict = field(default_factory=dict)
    #: when the campaign's recordings were taken (ISO times, by recording)
    recording_times: dict = field(default_factory=dict)
    #: the calibration runs taken after the recordings (None: none)
    runs_after_recordings: list | None = None
    #: the campaign reader's warnings, and what was absent from the folder
    warnings: tuple = ()
    left_out: tuple = ()
    #: named effects dropped again, with their evidence
    dropped: tuple = ()
    #: forms of the catalog left out of every fit (None: none)
    forms_left_out: dict | None = None
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

    @property
    def extra(self) -> dict:
        """The JSON's keys after ``seconds`` as one dict, each typed part as its JSON:
        ``mismatch_evidence``, ``verdict_fit``, ``alternatives``, ``upper_limits``,
        ``next_measurement``
        (:attr:`proposal`), ``null_range``, ``explained_fraction``, ``null_model``,
        ``refits`` (when asked for), ``generic``, ``timing_seconds``, ``nuisances``,
        ``recording_times``, ``runs_after_recordings``, ``warnings``, ``left_out``,
        ``dropped`` and ``forms_left_out`` (when forms were left out)."""
        out = {"mismatch_evidence": list(self.mismatch_evidence),
               "verdict_fit": self.verdict_fit,
               "alternatives": [a.to_dict() for a in self.alternatives],
               "upper_limits": [u.to_dict() for u in self.upper_limits],
               "next_measurement": None if self.proposal is None else self.proposal.to_dict(),
               "null_range": self.null_range, "explained_fraction": self.explained_fraction,
               "null_model": None if self.null_model is None else self.null_model.to_dict()}
        if self.refits is not None:
            out["refits"] = self.refits
        out.update(generic=self.generic, timing_seconds=self.timing_seconds,
                   nuisances=self.nuisances, recording_times=self.recording_times,
                   runs_after_recordings=self.runs_after_recordings,
                   warnings=list(self.warnings), left_out=list(self.left_out),
                   dropped=list(self.dropped))
        if self.forms_left_out:
            out["forms_left_out"] = self.forms_left_out
        return out

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

    def compared_with(self, previous) -> Comparison:
        """What the recordings added since ``previous`` changed (an earlier diagnosis of the
        campaign: a Diagnosis, its JSON dict or file;
        :func:`~dpdfit.analyses.diagnosis.comparison.compare.compare_diagnoses`)."""
        return compare_diagnoses(previous, self)

    def schedule(self, campaign=None) -> pd.DataFrame:
        """The proposed recording (:attr:`proposal`) as a schedule: one row per point
        and repeat, the table ``dpdfit diagnose --schedule`` writes
        (:func:`~dpdfit.analyses.diagnosis.proposal.schedule.proposal_schedule`).
        ``campaign``: the campaign folder the diagnosis read (default: :attr:`campaign`),
        whose grids, phases and times the recording repeats."""
        return proposal_schedule(None if self.proposal is None else self.proposal.to_dict(),
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
        """The text report (:func:`~dpdfit.analyses.diagnosis.rendering.report_text`)."""
        return report_text(self)
