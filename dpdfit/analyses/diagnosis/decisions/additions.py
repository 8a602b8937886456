"""Forward selection of further effects: an addition is named only if every form of the
named families needs it.

After the first named effect the diagnosis adds further effects one at a time
(:func:`add_effects`).  A candidate is a family; it is added when

1. **it is decisive** against the named model on the tempered evidence, as a
   family: its gain is the best form's (the form it was fitted in jointly)
   less ``2 ln F`` for having chosen that form among its family's ``F``
   (:func:`~dpdfit.analyses.diagnosis.evidence.families.family_evidence`), its
   likelihood-ratio p-value Bonferroni-corrected over those forms and over
   the candidates;
2. **every form of the named families needs it** (:func:`room_for`): the named
   families are refitted in each of their other *maximal* forms
   (:func:`~dpdfit.analyses.diagnosis.evidence.families.maximal_forms`), with and
   without the candidate, and the candidate must be decisive against each.
   If one form of a named family leaves no room for it, what it patches is
   the named family's form, not a second cause: it is not added, and it is
   listed as an addition in reach (``room`` names the form that leaves none);
3. on the side of an effect already named, it removes at least
   ``DOMINANT_FRACTION`` of what the named effects of that side removed.

Candidates are the single effects decisive against the baseline on their own,
acting on a side where the named model still shows a mismatch, or on the gates
whenever the campaign's gates showed one: the gates' targeted test is run again
at every step, since a gate-side candidate decisive against the named model is
that test (a weak gate effect beside a tone effect leaves no located interval).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.analyses.diagnosis.evidence.families import (family_evidence, form_gain,
                                                         maximal_forms)
from dpdfit.analyses.diagnosis.evidence.mismatches import locate_mismatches, side_evidence
from dpdfit.analyses.diagnosis.evidence.ranking import decisive, rank_entry
from dpdfit.analyses.diagnosis.evidence.thresholds import BIC_DECISIVE, DOMINANT_FRACTION
from dpdfit.analyses.diagnosis.fitting.fit_result import (FitResult, combine_sides,
                                                          param_side)
from dpdfit.analyses.diagnosis.fitting.hypothesis_fit import fit_all, fit_hypothesis
from dpdfit.analyses.diagnosis.fitting.phase_sign import repredict_gates, tone_held

__all__ = ["Selection", "select_from", "add_effects", "prune", "addition_entry", "room_for",
           "use_field_of", "set_gain", "MAX_EFFECTS", "ADD_NFEV"]

#: at most this many effects are named
MAX_EFFECTS = 3
#: evaluations of a joint fit of an added effect (it starts from both optima)
ADD_NFEV = 40


def addition_entry(prob, ref: FitResult, f: FitResult) -> dict:
    """The ranking entry of ``f`` (``ref`` plus one family) against ``ref``, with the
    added family's evidence: its one fitted form, paid for among its family's forms."""
    entry = rank_entry(ref, f)
    c = f.effects[-1]
    fe = family_evidence(c, ref, {f.forms[-1]: f}, n_forms=len(prob.forms_of(c)))
    return {**entry, **fe.to_dict()}


def use_field_of(prob, chosen: FitResult) -> bool:
    """The gate model of the named tone-side effect's field (carried, if it was): whether
    the gate model changed (the gate-side single fits were made with the other one)."""
    carried = getattr(prob, "carried", None) or {}
    for name in chosen.effects:
        if name in carried:
            prob.use_tone(carried[name][0])
            prob.gate = carried[name][1]
            return True
    return False


def _fit_keys(prob, f: FitResult) -> set:
    """Parameters of ``f`` a fit may hold: nuisances with a prior and effect parameters."""
    return set(prob.prior) | set(f.params)


def _held_other_side(prob, f: FitResult, side: str) -> dict:
    """``f``'s parameters of the side other than ``side`` that a fit may hold."""
    return {k: v for k, v in f.all_params.items()
            if param_side(prob, k) != side and k in _fit_keys(prob, f)}


def _candidates(ranking: list, named: set, left: set, located: set, pairs: int) -> list:
    """The effects tried as an addition to the ``named`` ones, at most ``pairs``: those
    decisive on their own against the baseline on a side still searched (``left``),
    best first; then, in the room left, those that were not, on a side where the named
    model itself leaves a located mismatch (``located``).  An effect can be masked in
    the baseline: a gate-side one whose signature the baseline's field hides, seen only
    once a tone-side effect carries its own field to the gates (the parity contrast the
    baseline fitted, misfitted under the named field)."""
    others = [r for r in ranking if "+" not in r["effect"] and r["effect"] not in named]
    alone = [r["effect"] for r in others if EFFECTS[r["effect"]].side in left
             and r["delta_bic"] < -BIC_DECISIVE]
    masked = [r["effect"] for r in others if EFFECTS[r["effect"]].side in located
              and r["effect"] not in alone]
    return (alone + masked)[:pairs]


def add_effects(prob, base: FitResult, chosen: FitResult, fits: dict, form_fits: dict,
                ranking: list, pairs: int, sides: set):
    """Forward selection (module doc).  Returns the final fit, the steps (ranking entries
    of the candidates tried, per step), the chain of fits (one per named effect) and,
    per step, ``(entries, added, refused)``: the candidates' ``(entry, fit)``, the fit
    added (or None) and the ``(entry, fit, room)`` of candidates decisive against the
    named model that a form of a named family leaves no room for."""
    steps, chain, tried = [], [chosen], []
    rebased = prob.gate is not None and use_field_of(prob, chosen)
    while len(chosen.effects) < MAX_EFFECTS:
        named = set(chosen.effects)
        # a side is searched again while the named model leaves a mismatch there; the
        # gates also while the campaign's gates showed one (the targeted test again)
        located = side_evidence(chosen, locate_mismatches(prob, chosen.all_params), [])
        left = located & sides
        if prob.gate is not None and "gates" in sides:
            left = left | {"gates"}
        cands = _candidates(ranking, named, left, located, pairs)
        if not cands:
            break
        done = _joint_fits(prob, base, chosen, fits, cands, rebased)
        entries = sorted(((addition_entry(prob, chosen, f), f) for f in done),
                         key=lambda ef: ef[0]["family_delta_bic_tempered"])
        steps.append([e for e, _ in entries])
        added, refused = None, []
        for entry, f in entries:
            if not (decisive(entry, len(cands)) and _not_a_refinement(base, chosen, f)):
                continue
            room = room_for(prob, base, chosen, f, form_fits, len(cands))
            if room is None:
                added = f
                break
            refused.append((entry, f, room))
        tried.append((entries, added, refused))
        if added is None:
            break
        chosen = added
        chain.append(added)
        prob.n_tests_of = {**getattr(prob, "n_tests_of", {}), added.effects[-1]: len(cands)}
    tone_side = [e for e in chosen.effects if EFFECTS[e].side == "tones"]
    if prob.gate is not None and tone_side and len(chosen.effects) > 1:
        # the gates under the final field (the tone effects held at their joint fit)
        chosen = repredict_gates(prob, chosen, keep_sign=True)
        chain[-1] = chosen
    return chosen, steps, chain, tried


def _joint_fits(prob, base, chosen, fits, cands, rebased) -> list:
    """Each candidate fitted jointly with the named effects, in its best single form."""
    jobs, done = [], {}
    for c in cands:
        side = EFFECTS[c].side
        if not any(EFFECTS[e].side == side for e in chosen.effects) and not (
                rebased and side == "gates"):
            # the sides share no parameter: the joint optimum is the named effects'
            # side of ``chosen`` and the candidate's side of its single fit
            done[c] = combine_sides(prob, chosen, fits[c], side)
            continue
        hyp = chosen.hypothesis + ((c, fits[c].forms[0]),)
        jobs.append((c, (hyp, dict(starts=[{**chosen.params, **fits[c].params}],
                                   fixed=_held_other_side(prob, chosen, side),
                                   max_nfev=ADD_NFEV,
                                   init={**base.nuisances, **chosen.nuisances}))))
    for (c, (hyp, _)), f in zip(jobs, fit_all(prob, [j for _, j in jobs])):
        # the other side was held at the named model's: its values and covariance
        done[c] = combine_sides(prob, chosen, f, EFFECTS[c].side, hyp=hyp)
    return [done[c] for c in cands]


def _not_a_refinement(base: FitResult, chosen: FitResult, f: FitResult) -> bool:
    """The added effect is not merely refining the named effects of its side (see
    DOMINANT_FRACTION): it removes enough chi2 on that side compared with them."""
    added = f.effects[-1]
    side = EFFECTS[added].side
    same = [e for e in chosen.effects if EFFECTS[e].side == side]
    if not same:
        return True

    def side_chi2(r: FitResult) -> float:
        return sum(v for k, v in r.chi2_by_observable.items()
                   if (k.startswith("tones:") or k.startswith("runs:")) == (side == "tones"))

    named_gain = side_chi2(base) - side_chi2(chosen)
    return side_chi2(chosen) - side_chi2(f) >= DOMINANT_FRACTION * max(named_gain, 0.0)


# ----------------------------------------------------------------- whole selections
@dataclass
class Selection:
    """One forward selection from a first effect: the final fit, the steps (ranking
    entries per step), the chain of fits, the candidates tried per step (see
    :func:`add_effects`), the additions dropped again (:func:`prune`), the models the
    problem ended on (the gates on the named field) and the set's gain
    (:func:`set_gain`)."""

    start: str
    chosen: FitResult
    steps: list
    chain: list
    tried: list
    dropped: list = field(default_factory=list)
    models: tuple = ()
    gain: float = -np.inf


def set_gain(prob, base: FitResult, f: FitResult) -> float:
    """The tempered gain of a set of effects against the baseline, each family paying
    ``2 ln F`` for the form it was fitted in among its ``F``."""
    cost = sum(2 * np.log(max(len(prob.forms_of(e)), 1)) for e in f.effects)
    return form_gain(base, f)[1] - cost


def select_from(prob, base: FitResult, start: FitResult, fits: dict, form_fits: dict,
                ranking: list, pairs: int, sides: set) -> Selection:
    """The forward selection from first effect ``start`` (:func:`add_effects`), its
    additions checked again once the set is complete (:func:`prune`).  The problem
    starts from its baseline models and is left on the selection's."""
    tone, gate = getattr(prob, "base_models", (prob.tone, prob.gate))
    prob.use_tone(tone)
    prob.gate = gate
    chosen, steps, chain, tried = start, [], [start], []
    if pairs > 0:
        chosen, steps, chain, tried = add_effects(prob, base, start, fits, form_fits,
                                                  ranking, pairs, sides)
    chosen, chain, dropped = prune(prob, base, chosen, chain, form_fits)
    return Selection(start.effects[0], chosen, steps, chain, tried, dropped,
                     (prob.tone, prob.gate), set_gain(prob, base, chosen))


def _reordered(f: FitResult, last: str) -> FitResult:
    """``f`` with effect ``last`` moved to the end of its hypothesis."""
    hyp = [h for h in f.hypothesis if h[0] != last] + [h for h in f.hypothesis if h[0] == last]
    return dataclasses.replace(f, effect="+".join(e for e, _ in hyp),
                               forms=tuple(fo for _, fo in hyp))


def prune(prob, base: FitResult, chosen: FitResult, chain: list, form_fits: dict):
    """Each gate-side addition checked again once every other effect is named: it must
    still be decisive against the others refitted without it and have room against
    their maximal forms (:func:`room_for`); otherwise it is dropped (the last such
    first) and the check repeated.  A tone-side addition was judged against every tone
    form already.  Returns ``(chosen, chain, dropped)``, ``dropped`` the ``(effect,
    entry)`` of each addition dropped."""
    dropped = []
    n_tests_of = getattr(prob, "n_tests_of", {})
    while len(chosen.effects) > 1:
        for e in reversed(chosen.effects[1:]):
            if EFFECTS[e].side != "gates":
                continue
            without = _refit_without(prob, base, chosen, e)
            f = _reordered(chosen, e)
            n = n_tests_of.get(e, 1)
            entry = addition_entry(prob, without, f)
            if decisive(entry, n) and room_for(prob, base, without, f, form_fits, n) is None:
                continue
            dropped.append((e, entry))
            chosen = without
            chain = [c for c in chain if e not in c.effects]
            if len(chain) < len(without.effects):
                chain.append(without)
            else:
                chain[-1] = without
            break
        else:
            break
    return chosen, chain, dropped


def _refit_without(prob, base: FitResult, chosen: FitResult, e: str) -> FitResult:
    """``chosen`` refitted without gate-side effect ``e`` (the tones held)."""
    hyp = tuple(h for h in chosen.hypothesis if h[0] != e)
    pre = e + "."
    start = {k: v for k, v in chosen.params.items() if not k.startswith(pre)}
    f = fit_hypothesis(prob, hyp, starts=[start],
                       fixed=_held_other_side(prob, chosen, "gates"), max_nfev=ADD_NFEV,
                       init={**base.nuisances, **chosen.nuisances})
    return combine_sides(prob, chosen, f, "gates", hyp=hyp)


# ----------------------------------------------------------------- room
def _form_matters(prob, named: str, cand: str) -> bool:
    """Whether named family ``named``'s form can change what candidate ``cand`` adds:
    on the same side, or a tone-side family whose field the gates are predicted from
    for a gate-side candidate.  A tone-side candidate beside a gate-side family is
    judged on the tones, where the family's form plays no part."""
    a, b = EFFECTS[named].side, EFFECTS[cand].side
    return a == b or (a == "tones" and b == "gates" and prob.gate is not None)


def room_for(prob, base: FitResult, chosen: FitResult, f: FitResult, form_fits: dict,
             n_tests: int) -> dict | None:
    """None when the candidate that ``f`` adds to ``chosen`` is needed against every
    other maximal form of each named family (module doc); else what leaves no room:
    the addition's entry against that form, with ``family`` and ``form``."""
    cand = f.effects[-1]
    for name, form in chosen.hypothesis:
        if not _form_matters(prob, name, cand):
            continue
        for m in maximal_forms(prob.forms_of(name)):
            if m.name == form or m.name not in form_fits.get(name, {}):
                continue
            without, with_c = _refit_in_form(prob, base, chosen, f, name, m.name,
                                             form_fits[name][m.name])
            entry = addition_entry(prob, without, with_c)
            if not decisive(entry, n_tests):
                return {**entry, "family": name, "form": m.name}
    return None


def _swap_form(hyp, name: str, form: str) -> tuple:
    return tuple((e, form if e == name else fo) for e, fo in hyp)


def _start(fit: FitResult, name: str, single: FitResult) -> dict:
    """``fit``'s effect parameters with family ``name``'s taken from its fit ``single``
    in another form."""
    pre = name + "."
    return {**{k: v for k, v in fit.params.items() if not k.startswith(pre)},
            **{k: v for k, v in single.params.items() if k.startswith(pre)}}


def _refit_in_form(prob, base, chosen, f, name, form, single):
    """``(N', N' + candidate)``: the named model ``chosen`` and ``f`` (it plus the
    candidate) refitted with family ``name`` in ``form`` (its single fit ``single``
    starts it).  A tone-side family with a gate-side candidate: the tones refitted,
    the gates re-predicted from that field (the phase-sign convention kept) and both
    gate hypotheses refitted on them."""
    hyp_wo = _swap_form(chosen.hypothesis, name, form)
    hyp_w = _swap_form(f.hypothesis, name, form)
    side = EFFECTS[name].side
    init = {**base.nuisances, **chosen.nuisances}
    if side == "tones" and EFFECTS[f.effects[-1]].side == "gates":
        tone_hyp = tuple((e, fo) for e, fo in hyp_wo if EFFECTS[e].side == "tones")
        tone = fit_hypothesis(prob, tone_hyp, starts=[_start(chosen, name, single)],
                              fixed=_held_other_side(prob, chosen, "tones"),
                              max_nfev=ADD_NFEV, init=init)
        held = tone_held(prob, tone)
        saved = prob.gate
        try:
            prob.gate = saved.rebased(prob.tone, held)
            gate_fits = fit_all(prob, [
                (tuple((e, fo) for e, fo in h if EFFECTS[e].side == "gates"),
                 dict(starts=[{k: v for k, v in g.params.items()
                               if param_side(prob, k) == "gates"}],
                      fixed=held, init=g.all_params, max_nfev=ADD_NFEV))
                for h, g in ((hyp_wo, chosen), (hyp_w, f))])
            # chi2 and residuals under the rebased gates, before they are put back
            return tuple(combine_sides(prob, g, tone, "tones", hyp=h)
                         for g, h in zip(gate_fits, (hyp_wo, hyp_w)))
        finally:
            prob.gate = saved
    out = fit_all(prob, [(h, dict(starts=[_start(g, name, single)],
                                  fixed=_held_other_side(prob, g, side),
                                  max_nfev=ADD_NFEV, init=init))
                         for h, g in ((hyp_wo, chosen), (hyp_w, f))])
    return tuple(combine_sides(prob, g0, r, side, hyp=h)
                 for r, g0, h in zip(out, (chosen, f), (hyp_wo, hyp_w)))
