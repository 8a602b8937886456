"""Discrepancy diagnosis: locate, name, model and show the improvement (issue #7).

Steps (:func:`diagnose`):

1. **Baseline.**  The simulation built from the campaign's own calibration
   (:mod:`dpdfit.analyses.diagnosis.tone_model`,
   :mod:`dpdfit.analyses.diagnosis.gate_model`) predicts every observable of
   :mod:`dpdfit.analyses.diagnosis.observables`
   (:class:`~dpdfit.analyses.diagnosis.problem.Problem`).  Its existing
   parameters (nuisances) are refitted first, with Gaussian priors from the
   calibration: if that absorbs the mismatch there is nothing to explain.
2. **Locate.**  Standardised residuals ``z = (recorded - simulated)/sigma`` of
   each series (observable x sideband x flag, ordered by A, xi0 or t) are
   scanned for intervals of significant deviation (:func:`dpdfit.analyses.diagnosis.scan.scan_intervals`),
   Bonferroni-corrected over all intervals and all series.
3. **Name.**  Each catalog effect (:mod:`dpdfit.analyses.diagnosis.effects`)
   and its variants, and pairs of the three best, is fitted jointly to all
   observables (nuisances refitted with it) by ``scipy.optimize.least_squares``
   (:mod:`dpdfit.analyses.diagnosis.fitting`); effects are ranked by
   ``delta_bic = BIC(effect) - BIC(baseline)`` (negative favours the effect)
   and a likelihood-ratio test (``p_value``: Wilks, chi2 with as many degrees
   of freedom as the effect has parameters).  The best tone-side effect's
   gates are re-predicted under both phase-sign conventions
   (:mod:`dpdfit.analyses.diagnosis.phase_sign`).
4. **Verdict** (:mod:`dpdfit.analyses.diagnosis.verdict`).  ``"none"`` when
   there is no evidence of a mismatch: the baseline's global chi2 p-value,
   every located interval and the targeted test (the best single effect's LRT
   p-value times the number of effects tried, with ``delta_bic <
   -BIC_DECISIVE``) are all above ``ALPHA`` (``mismatch_evidence`` lists which
   fired); else the best effect if it is decisive (``delta_bic <
   -BIC_DECISIVE``, LRT ``p < ALPHA``) *and* leaves an acceptable fit (chi2
   p-value >= ``ALPHA_FIT``); a pair ``"a+b"`` when only a pair does that; else
   ``"unexplained"``.

Parameter errors are the Gauss-Newton ones, ``(J^T J)^-1`` of the standardised
residuals at the optimum (1 sigma), with the calibration's error modes profiled
out, so they include the calibration uncertainty; ``params_err`` is NaN when a
parameter sits at its bound.
"""

from __future__ import annotations

import itertools
import time

from threadpoolctl import threadpool_limits

from dpdfit.core.progress import progress_bar

from dpdfit.analyses.diagnosis.effects import EFFECTS, VARIANTS, effect_form, form_key
from dpdfit.analyses.diagnosis.fitting import FitResult, fit_all, fit_hypothesis
from dpdfit.analyses.diagnosis.gate_model import GATE_NUISANCES
from dpdfit.analyses.diagnosis.observables import load_campaign
from dpdfit.analyses.diagnosis.phase_sign import refit_other_sign, repredict_gates
from dpdfit.analyses.diagnosis.problem import NUISANCES, Problem
from dpdfit.analyses.diagnosis.result import Diagnosis
from dpdfit.analyses.diagnosis.verdict import (ALPHA, ALPHA_FIT, BIC_DECISIVE, choose_verdict,
                                               explained_fraction, fidelity_impact,
                                               locate_mismatches, mismatch_evidence,
                                               rank_entry)

__all__ = ["diagnose", "Diagnosis", "Problem", "mismatch_evidence", "ALPHA", "BIC_DECISIVE",
           "DEFAULT_EFFECTS", "DEFAULT_PAIRS"]

#: effects considered by default (in this order)
DEFAULT_EFFECTS = ("am_pm_omitted", "aom_memory", "stale_calibration", "higher_order_im",
                   "detector_nonlinearity", "motional_heating", "dephasing", "spam_offset",
                   "gate_rate_miscalibration")
#: pairs of this many best single effects are fitted when there is a mismatch
DEFAULT_PAIRS = 3


def diagnose(folder, effects=DEFAULT_EFFECTS, pairs: int = DEFAULT_PAIRS,
             with_gates: bool = True, run_fits: dict | None = None,
             progress: bool | None = None) -> Diagnosis:
    """Diagnose a campaign folder (see module doc).

    Parameters
    ----------
    folder : path-like
        Campaign folder (``dpdfit simulate-campaign`` layout).
    effects : iterable of str
        Catalog effects to consider (:data:`dpdfit.analyses.diagnosis.effects.EFFECTS`).
    pairs : int
        Fit the pairs of this many best single effects (0: none).
    with_gates : bool
        Use the gate recordings (else the tone side alone, tone-side effects only).
    run_fits : dict, optional
        The amplitude runs' fits at the campaign's order, ``{run label: fit}``,
        when the caller has made them (``dpdfit analyze`` does): not refitted.
    progress : bool, optional
        A bar over the stages (baseline, single effects, pairs, verdict); default:
        when stderr is a terminal (:mod:`dpdfit.core.progress`).

    BLAS runs single-threaded meanwhile: the engine's many small matrix products
    are 1.5x slower with threaded BLAS (measured on the bundled campaign), and the
    independent engine runs use the cores instead (:mod:`dpdfit.core.parallel`).
    """
    with (threadpool_limits(limits=1, user_api="blas"),
          progress_bar(total=4, desc="diagnose", progress=progress) as bar):
        return _diagnose(folder, effects, pairs, with_gates, run_fits, bar)


def _diagnose(folder, effects, pairs: int, with_gates: bool, run_fits, bar) -> Diagnosis:
    t0 = time.perf_counter()
    camp = load_campaign(folder, run_fits)
    prob = Problem(camp, with_gates=with_gates)
    effects = tuple(e for e in effects if with_gates or EFFECTS[e].side == "tones")
    base = fit_hypothesis(prob, ())
    mismatches = locate_mismatches(prob, {**base.nuisances})
    bar.update()
    fits = _fit_singles(prob, base, effects)
    bar.update()
    ranking = _rank_singles(prob, base, fits)
    if prob.gate is not None and _carry_tone_best(prob, base, fits, ranking):
        ranking = _rank_singles(prob, base, fits)
    evidence = mismatch_evidence(base.p_fit, mismatches, ranking)
    top = [r["effect"] for r in ranking[:pairs]]
    pair_fits = {}
    best_ok = bool(ranking) and ranking[0]["p_fit"] >= ALPHA_FIT
    if evidence and pairs >= 2 and not best_ok:
        pair_fits = _fit_pairs(prob, base, fits, top)
        ranking = sorted(ranking + [rank_entry(base, f) for f in pair_fits.values()],
                         key=lambda r: r["delta_bic"])
    bar.update()
    verdict, chosen, approximate = ("none", None, False) if not evidence else choose_verdict(
        ranking, fits, pair_fits)
    after = chosen or base
    pb = {**base.nuisances}
    pa = pb if chosen is None else {**chosen.nuisances, **chosen.params}
    bar.update()
    return Diagnosis(campaign=str(folder), mismatches=mismatches, ranking=ranking,
                     verdict=verdict, redchi_before=base.redchi(), redchi_after=after.redchi(),
                     baseline=base, chosen=chosen, baseline_p_value=base.p_fit,
                     seconds=time.perf_counter() - t0,
                     extra={"mismatch_evidence": evidence,
                            "verdict_fit": ("none" if chosen is None else "approximate"
                                            if approximate else "acceptable"),
                            "explained_fraction": (None if chosen is None
                                                   else explained_fraction(base, chosen)),
                            "nuisances": {**{k: NUISANCES[k][0] for k in NUISANCES},
                                          **{k: v[0] for k, v in GATE_NUISANCES.items()}},
                            "null_model": prob.null_model(base),
                            "warnings": list(camp.warnings),
                            "left_out": list(camp.left_out)},
                     series_before=prob.series(pb), series_after=prob.series(pa))


def _side_nuisances(prob: Problem, base: FitResult, side: str) -> dict:
    """The baseline's optimum of the nuisances of one side (``"tones"`` or ``"gates"``)."""
    return {k: v for k, v in base.nuisances.items()
            if (k in prob.tone_nuisances) == (side == "tones")}


def _held(prob: Problem, base: FitResult, keys) -> dict:
    """Nuisances held at the baseline's optimum in the fit of effects ``keys``: the
    other side's, when every effect acts on one side (the sides share no parameter)."""
    sides = {effect_form(e).side for e in keys}
    if sides == {"tones"}:
        return _side_nuisances(prob, base, "gates")
    return _side_nuisances(prob, base, "tones") if sides == {"gates"} else {}


def _fit_singles(prob: Problem, base: FitResult, effects: tuple) -> dict:
    """Every single effect and every variant (a catalog effect's other form) the campaign
    supports, fitted independently over the cores; the better form by BIC is the effect's
    fit: catalog name -> FitResult."""
    keys = list(effects) + [k for k, v in VARIANTS.items()
                            if v.name in effects and v.for_campaign(prob.tone).params]
    done = fit_all(prob, [((k,), dict(fixed=_held(prob, base, (k,)), init=base.nuisances))
                          for k in keys])
    fits = {}
    for k, f in zip(keys, done):
        name = k.split("@")[0]
        if name not in fits or f.bic < fits[name].bic:
            fits[name] = f
    return fits


def _rank_singles(prob: Problem, base: FitResult, fits: dict) -> list:
    return sorted((rank_entry(base, f, fidelity_impact(prob, f)) for f in fits.values()),
                  key=lambda r: r["delta_bic"])


def _carry_tone_best(prob: Problem, base: FitResult, fits: dict, ranking: list) -> bool:
    """The best tone-side effect also changes the gates' spectra: when it is decisive,
    its gates are re-predicted with its field and refitted (tone parameters held at their
    fit), under the other phase sign too (refitted there when its spectra depend on
    the sign).  Updates ``fits``; returns whether it did."""
    tone_best = next((r["effect"] for r in ranking if EFFECTS[r["effect"]].side == "tones"),
                     None)
    if tone_best is None or not fits[tone_best].bic < base.bic - BIC_DECISIVE:
        return False
    f = repredict_gates(prob, fits[tone_best])
    if (prob.camp.phase is not None
            and effect_form(form_key(f.effect, f.variant)).sign_sensitive):
        f = refit_other_sign(prob, f, _side_nuisances(prob, base, "gates"), base.nuisances)
    fits[tone_best] = f
    return True


def _fit_pairs(prob: Problem, base: FitResult, fits: dict, top: list) -> dict:
    """Every pair of the effects ``top``, each in its better form, started from the two
    single fits: ``"a+b"`` -> FitResult."""
    def key(e):
        return form_key(e, fits[e].variant)

    combos = list(itertools.combinations(top, 2))
    done = fit_all(prob, [((key(a), key(b)), dict(
        starts=[{**fits[a].params, **fits[b].params}],
        fixed=_held(prob, base, (key(a), key(b))), init=base.nuisances)) for a, b in combos])
    return {f"{a}+{b}": f for (a, b), f in zip(combos, done)}
