"""Discrepancy diagnosis: locate, name, model, size and show the improvement.

Steps (:func:`diagnose`):

1. **Baseline.**  The simulation built from the campaign's own calibration
   (:mod:`~dpdfit.analyses.diagnosis.model.tones.tone_model`,
   :mod:`~dpdfit.analyses.diagnosis.model.gates.gate_model`) predicts every observable of
   :mod:`~dpdfit.analyses.diagnosis.observables.campaign`
   (:class:`~dpdfit.analyses.diagnosis.model.residuals.Problem`).  Its nuisances (what
   the lab does not know, learnt first) are refitted: if that absorbs the
   mismatch there is nothing to explain.
2. **Locate.**  Standardised residuals of each series are scanned for
   intervals of significant deviation, Bonferroni-corrected over all intervals
   and series (:func:`~dpdfit.analyses.diagnosis.evidence.mismatches.locate_mismatches`).
3. **Name.**  Every form of each catalog effect
   (:mod:`~dpdfit.analyses.diagnosis.effects`) is fitted with the nuisances
   (:func:`~dpdfit.analyses.diagnosis.fitting.hypothesis_fit.fit_effect`; the better form by
   BIC is the effect's fit), ranked by ``delta_bic = BIC(effect) -
   BIC(baseline)`` and a likelihood-ratio test.  The tone-side effects' field
   also re-predicts the gates, under both phase-sign conventions
   (:mod:`~dpdfit.analyses.diagnosis.fitting.phase_sign`).
4. **More than one.**  After the best single effect, every other effect is
   tested as an addition to the named ones (fitted jointly, started from the
   two fits) with the same criteria -- decisive BIC, likelihood-ratio test
   Bonferroni-corrected over the candidates -- until none is decisive.
5. **Verdict** (:mod:`~dpdfit.analyses.diagnosis.evidence.mismatches`): ``"none"`` when
   no test finds a mismatch; else the first named effect (``effects`` lists
   all, best first) when the named effects leave an acceptable fit or the
   first explains nearly all of the mismatch; else ``"unexplained"``, with the
   located mismatches and a smooth generic discrepancy fitted in their place
   (:mod:`~dpdfit.analyses.diagnosis.evidence.generic_discrepancy`).
6. **How big.**  Each named effect's size in a laboratory's terms with 1-sigma
   errors (Gauss-Newton, the calibration's error modes profiled out; profile
   likelihood where the curvature is poor, e.g. at a bound) and its cost in
   Bell fidelity.
7. **Alternatives.**  The hypotheses the recordings do not separate from the named ones
   (:mod:`~dpdfit.analyses.diagnosis.decisions.alternatives`); an addition whose fitted
   size is consistent with zero is an upper limit on that effect instead
   (:mod:`~dpdfit.analyses.diagnosis.decisions.upper_limits`), and the proposed
   recording is aimed at the strongest open alternative.
"""

from __future__ import annotations

import dataclasses
import time

from threadpoolctl import threadpool_limits

from dpdfit.analyses.diagnosis.comparison.refits import refit_chi2s, refit_labels
from dpdfit.analyses.diagnosis.decisions.alternatives import (addition_alternatives,
                                                              swap_alternatives)
from dpdfit.analyses.diagnosis.decisions.explanations import (open_sides, select,
                                                              start_alternatives)
from dpdfit.analyses.diagnosis.decisions.first_effect import choose_first
from dpdfit.analyses.diagnosis.decisions.named_effects import named_effects
from dpdfit.analyses.diagnosis.decisions.upper_limits import split_upper_limits
from dpdfit.analyses.diagnosis.effects import EFFECTS, default_effects, get
from dpdfit.analyses.diagnosis.evidence.families import family_evidence
from dpdfit.analyses.diagnosis.evidence.generic_discrepancy import generic_discrepancy
from dpdfit.analyses.diagnosis.evidence.mismatches import (locate_mismatches,
                                                           mismatch_evidence, side_evidence,
                                                           within_null_range)
from dpdfit.analyses.diagnosis.evidence.ranking import explained_fraction, rank_entry
from dpdfit.analyses.diagnosis.evidence.thresholds import (ALPHA, ALPHA_FIT, BIC_DECISIVE,
                                                           EXPLAINED_FRACTION,
                                                           NULL_REDCHI_MAX)
from dpdfit.analyses.diagnosis.fitting.fit_result import FitResult
from dpdfit.analyses.diagnosis.fitting.hypothesis_fit import fit_effects, fit_hypothesis
from dpdfit.analyses.diagnosis.fitting.phase_sign import carry
from dpdfit.analyses.diagnosis.model.gates.gate_model import GATE_NUISANCES
from dpdfit.analyses.diagnosis.model.residuals import (NUISANCES, Problem,
                                                       check_forms_left_out)
from dpdfit.analyses.diagnosis.observables.campaign import Campaign, load_campaign
from dpdfit.analyses.diagnosis.proposal.next_measurement import NextMeasurement
from dpdfit.analyses.diagnosis.proposal.propose import propose
from dpdfit.analyses.diagnosis.result import Diagnosis
from dpdfit.core.defaults import DIAGNOSIS_PAIRS
from dpdfit.core.progress import progress_bar

__all__ = ["diagnose", "Diagnosis", "Problem", "mismatch_evidence", "ALPHA", "BIC_DECISIVE",
           "DEFAULT_PAIRS"]

#: at most this many other effects are tried as an addition at each step, the best
#: single effects first (``dpdfit diagnose --pairs``; 0: one effect only)
DEFAULT_PAIRS = DIAGNOSIS_PAIRS


def diagnose(campaign, effects=None, pairs: int = DEFAULT_PAIRS,
             with_gates: bool = True, run_fits: dict | None = None,
             progress: bool | None = None, calibration=None, noise=None,
             forms_left_out: dict | None = None, refit: list | None = None) -> Diagnosis:
    """Diagnose a campaign (see module doc).

    Parameters
    ----------
    campaign : path-like, CampaignFolder or Campaign
        The campaign folder, its reader, or its recordings already read
        (:func:`~dpdfit.analyses.diagnosis.observables.campaign.load_campaign`).
    effects : iterable of str, optional
        Catalog effects to consider (default: the registry's default effects,
        :func:`~dpdfit.analyses.diagnosis.effects.default_effects`, read at the call).
    pairs : int
        At most this many other effects are tried as an addition to the named
        ones at each step (0: a single effect only).
    with_gates : bool
        Use the gate recordings (else the tone side alone, tone-side effects only).
    run_fits : dict, optional
        The amplitude runs' fits at the campaign's order, ``{run label: fit}``,
        when the caller has made them (``dpdfit analyze`` does): not refitted.
    progress : bool, optional
        A bar over the stages; default: when stderr is a terminal.
    calibration : Calibration, optional
        The fits of the model's amplitude and phase runs at the campaign's order,
        when the caller has made them (``dpdfit analyze`` does): not refitted.
    noise : tuple, optional
        ``(power noise, phase noise)``: the noise models of the calibration runs
        (:class:`~dpdfit.fits.photodiode.PowerNoise`, ``PhaseNoise`` or None each) when
        the caller has learnt them from every run (``dpdfit analyze``'s calibration
        step does): the runs are not refitted for them.
    forms_left_out : dict, optional
        ``{effect: [form, ...]}``: forms of the catalog left out of every fit (the
        harness's leave-one-form-out mode: how the diagnosis does when a lab's physics
        takes a form its catalog does not have).  An effect with every form left out
        is not considered.
    refit : list of dict, optional
        Hypotheses ``{"effects": [...], "forms": [...]}`` (e.g. the ``binding`` pair of
        an earlier diagnosis's ``next_measurement``) fitted again on this campaign
        (:func:`~dpdfit.analyses.diagnosis.comparison.refits.refit_label`): their chi2 are in
        :attr:`~dpdfit.analyses.diagnosis.result.Diagnosis.refits`, for the separation a
        recording achieved.

    Returns
    -------
    Diagnosis
        The verdict, the named effects (form, parameters, sizes) and the reduced
        chi2 per observable before and after.

    Notes
    -----
    BLAS runs single-threaded meanwhile: the engine's many small matrix products
    are 1.5x slower with threaded BLAS, and the independent fits and engine runs
    use the cores instead (:mod:`dpdfit.core.parallel`).
    """
    effects = tuple(default_effects() if effects is None else effects)
    for e in effects:
        get(e)                                            # a KeyError naming the known ones
    forms_left_out = check_forms_left_out(forms_left_out)
    with (threadpool_limits(limits=1, user_api="blas"),
          progress_bar(total=6, desc="diagnose", progress=progress) as bar):
        return _diagnose(campaign, effects, pairs, with_gates, run_fits, calibration, noise,
                         bar, forms_left_out, refit)


def _diagnose(campaign, effects, pairs: int, with_gates: bool, run_fits, calibration,
              noise, bar, forms_left_out=None, refit=None) -> Diagnosis:
    t0 = time.perf_counter()
    timing = {}

    def lap(stage):
        timing[stage] = time.perf_counter() - t0 - sum(timing.values())
        bar.update()

    camp = campaign if isinstance(campaign, Campaign) else load_campaign(campaign, run_fits,
                                                                         calibration, noise)
    effects = tuple(e for e in effects if (with_gates and camp.gates is not None)
                    or EFFECTS[e].side == "tones")
    prob = Problem(camp, with_gates=with_gates, effects=effects,
                   forms_left_out=forms_left_out)
    effects = tuple(e for e in effects if EFFECTS[e].supports(prob) and prob.forms_of(e))
    # the baseline's models, whatever field the gates are later carried to
    prob.base_models = (prob.tone, prob.gate)
    lap("null model")
    base = fit_hypothesis(prob, ())
    # the baseline's series and null model now: an effect's fit may re-choose the
    # phase-sign convention (phase_sign.repredict_gates), and the figures' baseline must
    # be the one behind redchi_before
    series_before, null_model = prob.series(dict(base.nuisances)), prob.null_model(base)
    mismatches = locate_mismatches(prob, dict(base.nuisances))
    lap("baseline")
    fits, form_fits = _fit_singles(prob, base, effects)
    ranking = _rank(prob, base, fits, form_fits)
    if prob.gate is not None:
        ranking = _carry_tone_best(prob, base, fits, form_fits, ranking)
    lap("single effects")
    evidence = mismatch_evidence(base.p_fit, mismatches, ranking)
    sides = side_evidence(base, mismatches, evidence)
    first, _ = (None, False) if not evidence else choose_first(ranking, len(ranking), sides)
    chosen, steps, chain, tried, others, dropped = None, [], [], [], [], []
    if first is not None:
        sel, others = select(prob, base, first, fits, form_fits, ranking, pairs, sides)
        first = sel.start
        chosen, steps, chain, tried, dropped = (sel.chosen, sel.steps, sel.chain, sel.tried,
                                                sel.dropped)
    lap("more effects")
    verdict, verdict_fit, named, chosen, unnamed, null_range = _verdict(
        base, chosen, evidence, mismatches)
    alts = ([] if not named else start_alternatives(prob, base, chosen, others, named)
            + swap_alternatives(fits, form_fits, ranking, first, named, sides,
                                exclude={o.start for o in others})
            + addition_alternatives(tried, named, open_sides(prob, chosen, sides)))
    # an addition whose size is consistent with zero is an upper limit, not a rival
    alts, limits = split_upper_limits(prob, alts)
    effects_out = (named_effects(prob, base, chosen, named, chain, form_fits)
                   if chosen is not None else [])
    lap("sizes")
    after = chosen or base
    pa = dict(base.nuisances) if chosen is None else chosen.all_params
    generic = None
    if verdict == "unexplained" or verdict_fit == "approximate":
        # the located mismatches with a smooth generic term in their place: where the
        # physics is missing, and how much of the excess chi2 it holds
        generic = generic_discrepancy(prob, (chosen or unnamed or base).all_params)
    one = fits[named[0]] if named else None
    nxt = _proposal(prob, base, chosen, alts, effects_out, form_fits)
    refits = refit_labels(prob, base, refit) if refit else None
    lap("report")
    return Diagnosis(
        campaign=str(camp.folder), mismatches=mismatches, ranking=ranking, verdict=verdict,
        redchi_before=base.redchi(), redchi_after=after.redchi(), baseline=base,
        chosen=chosen, baseline_p_value=base.p_fit, seconds=time.perf_counter() - t0,
        effects=effects_out, steps=steps,
        redchi_one=None if one is None else one.redchi(),
        mismatch_evidence=tuple(evidence), verdict_fit=verdict_fit,
        alternatives=tuple(a for a, _ in alts), upper_limits=limits, proposal=nxt,
        null_range=null_range,
        explained_fraction=None if chosen is None else explained_fraction(base, chosen),
        null_model=null_model, refits=refits, generic=generic, timing_seconds=timing,
        **_campaign_notes(prob, camp, dropped),
        series_before=series_before, series_after=prob.series(pa), context=prob)


def _proposal(prob: Problem, base: FitResult, chosen, alts: list, effects_out: list,
              form_fits: dict) -> NextMeasurement | None:
    """The next measurement (:func:`~dpdfit.analyses.diagnosis.proposal.propose.propose`)
    when the verdict has open alternatives (``alts``: the upper limits left out) or a
    poorly constrained size, aimed at the strongest alternative; its binding pair
    with the chi2 a later diagnosis will compare its own refit of them with."""
    if chosen is None or not (alts or any(e.get("poorly_constrained") for e in effects_out)):
        return None
    nxt = propose(prob, chosen, alts, effects_out, form_fits)
    if nxt.binding:
        # the binding pair fitted as a later diagnosis will fit it again: the gap the
        # recording starts from
        sides = list(nxt.binding)
        chi2 = refit_chi2s(prob, base, [nxt.binding[k] for k in sides])
        nxt = dataclasses.replace(nxt, binding={k: {**nxt.binding[k], "chi2": c}
                                                for k, c in zip(sides, chi2)})
    return nxt


def _campaign_notes(prob: Problem, camp, dropped: list) -> dict:
    """The Diagnosis's attributes that describe the campaign and the run rather than the
    verdict."""
    out = {"nuisances": {**{k: NUISANCES[k][0] for k in NUISANCES},
                         **{k: v[0] for k, v in GATE_NUISANCES.items()}},
           "recording_times": {k: v.isoformat() for k, v in camp.recorded.items()},
           "runs_after_recordings": (None if camp.runs_after is None
                                     else list(camp.runs_after.runs)),
           "warnings": tuple(camp.warnings), "left_out": tuple(camp.left_out),
           "dropped": tuple({"effect": e, **{k: v for k, v in en.items()
                                             if k in ("delta_bic", "delta_bic_tempered",
                                                      "family_delta_bic_tempered")}}
                            for e, en in dropped)}
    if prob.forms_left_out:
        out["forms_left_out"] = {k: sorted(v) for k, v in prob.forms_left_out.items()}
    return out


def _verdict(base: FitResult, chosen, evidence: list, mismatches: list):
    """``(verdict, verdict_fit, named, chosen, unnamed, null_range)`` from the selected
    fit (see :mod:`~dpdfit.analyses.diagnosis.evidence.mismatches`): a chosen fit that is not
    acceptable and explains too little is ``unnamed`` (not in the catalog); a campaign
    whose only evidence is the global chi2, with every observable in the null range, is
    ``none`` (``null_range``: the limit used)."""
    named = [] if chosen is None else list(chosen.effects)
    unnamed = None
    if (chosen is not None and chosen.p_fit < ALPHA_FIT
            and (explained_fraction(base, chosen) or 0.0) < EXPLAINED_FRACTION):
        # no acceptable fit and much left: what is missing is not in the catalog
        unnamed = chosen
        named, chosen = [], None
    verdict = ("none" if not evidence else named[0] if named else "unexplained")
    null_range = None
    if verdict == "unexplained" and unnamed is None and within_null_range(base, mismatches):
        # only the global chi2 says anything, nothing is located and every observable
        # sits where the harness's null campaigns sit: recordings noisier than stated
        verdict, null_range = "none", NULL_REDCHI_MAX
    verdict_fit = ("none" if chosen is None else "approximate"
                   if chosen.p_fit < ALPHA_FIT else "acceptable")
    return verdict, verdict_fit, named, chosen, unnamed, null_range


def _side_nuisances(prob: Problem, base: FitResult, side: str) -> dict:
    """The baseline's optimum of the nuisances of one side (``"tones"`` or ``"gates"``)."""
    return {k: v for k, v in base.nuisances.items()
            if (k in prob.tone_nuisances) == (side == "tones") and k != "phase_sign"}


def _held(prob: Problem, base: FitResult, names) -> dict:
    """Nuisances held at the baseline's optimum in the fit of effects ``names``: the
    other side's, when every effect acts on one side (the sides share no parameter)."""
    sides = {EFFECTS[e].side for e in names}
    if sides == {"tones"}:
        return _side_nuisances(prob, base, "gates") if prob.gate is not None else {}
    return _side_nuisances(prob, base, "tones") if sides == {"gates"} else {}


def _fit_singles(prob: Problem, base: FitResult, effects: tuple):
    """Every form of every effect, fitted independently over the cores; the better form
    by BIC is the effect's fit: ``({name: FitResult}, {name: {form: FitResult}})``."""
    done = fit_effects(prob, [(e, dict(fixed=_held(prob, base, (e,)), init=base.nuisances))
                              for e in effects])
    fits, forms = {}, {}
    for e, by_form in zip(effects, done):
        forms[e] = by_form
        fits[e] = min(by_form.values(), key=lambda f: f.bic)
    return fits, forms


def _rank(prob: Problem, base: FitResult, fits: dict, form_fits: dict) -> list:
    """Ranking entries of the single effects, best family evidence first: each effect's
    best form's entry with its family's evidence over every form
    (:func:`~dpdfit.analyses.diagnosis.evidence.families.family_evidence`; the best form's fit
    stands for the family where it was refitted, e.g. carried to the gates)."""
    out = []
    for name, f in fits.items():
        forms = {**form_fits.get(name, {}), **{f.forms[0]: f}}
        fe = family_evidence(name, base, forms)
        out.append({**rank_entry(base, f), **fe.to_dict()})
    return sorted(out, key=lambda r: (r["family_delta_bic_tempered"], r["delta_bic"]))


def _carry_tone_best(prob: Problem, base: FitResult, fits: dict, form_fits: dict,
                     ranking: list) -> list:
    """The best tone-side effect also changes the gates' spectra: when it is decisive,
    its gates are re-predicted with its field and refitted (:func:`carry`).  Updates
    ``fits``; returns the new ranking."""
    tone_best = next((r["effect"] for r in ranking if EFFECTS[r["effect"]].side == "tones"),
                     None)
    if tone_best is None or not fits[tone_best].bic < base.bic - BIC_DECISIVE:
        return ranking
    fits[tone_best] = carry(prob, base, fits[tone_best])
    return _rank(prob, base, fits, form_fits)
