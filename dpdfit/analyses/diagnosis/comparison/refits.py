"""The separation a recording achieved: named hypotheses fitted again, the same way on
the campaign before and after it.

A proposed recording (:mod:`~dpdfit.analyses.diagnosis.proposal.next_measurement`) names the
pair of hypotheses whose separation it predicts (``binding``: ``truth`` and
``rival``, each ``{"effects", "forms"}``).  :func:`refit_label` fits one such
hypothesis from scratch on a campaign's problem exactly as the diagnosis fits the
hypotheses it names (a gate-side one with the tones held at the baseline's optimum; a
tone-side part on the tones, its field carried to the gates under the better phase-sign
convention, the gate side refitted there), so that its chi2 before and after the
recording are comparable and the gap is the one the diagnosis decides by;
:func:`achieved_separation` is how far the recording moved the pair apart:
``|(chi2_rival - chi2_truth)_after - (chi2_rival - chi2_truth)_before|``, and
:func:`separation_direction` toward which side.
:func:`binding_refits` is the pair as the later diagnosis is asked to refit it,
:func:`binding_chi2` its chi2 before (kept in the proposal) and :func:`refitted_chi2`
after (the later diagnosis's ``extra["refits"]``), the two sides of that difference.
"""

from __future__ import annotations

import dataclasses

from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.analyses.diagnosis.fitting.fit_result import FitResult
from dpdfit.analyses.diagnosis.fitting.hypothesis_fit import fit_hypothesis, map_over_problem
from dpdfit.analyses.diagnosis.fitting.phase_sign import carry

__all__ = ["refit_label", "refit_labels", "refit_chi2s", "achieved_separation",
           "separation_direction", "binding_refits", "binding_chi2", "refitted_chi2"]

#: the two sides of a binding pair
_SIDES = ("truth", "rival")


def _held(prob, base: FitResult, names) -> dict:
    sides = {EFFECTS[e].side for e in names}
    if len(sides) != 1:
        return {}
    side = sides.pop()
    return {k: v for k, v in base.nuisances.items()
            if (k in prob.tone_nuisances) != (side == "tones") and k != "phase_sign"}


def refit_label(prob, base: FitResult, label: dict) -> float:
    """The chi2 of hypothesis ``label`` (``{"effects": [...], "forms": [...]}``) fitted on
    ``prob`` (module doc); ``base`` is that problem's baseline fit.  The problem's
    models are left as they were."""
    effects = list(label.get("effects") or ())
    if not effects:
        return float(base.chi2)
    hyp = tuple((e, f if f is not None else prob.forms_of(e)[0].name)
                for e, f in zip(effects, label.get("forms") or [None] * len(effects)))
    saved = prob.tone, prob.gate, getattr(prob, "carried", None)
    # the baseline's models (the diagnosis may have left the gates on a named field)
    tone, gate = getattr(prob, "base_models", saved[:2])
    try:
        prob.use_tone(tone)
        prob.gate = gate
        f = _fit_as_named(prob, base, hyp)
    finally:
        prob.use_tone(saved[0])
        prob.gate = saved[1]
        prob.carried = saved[2]
    return float(f.chi2)


def _fit_as_named(prob, base: FitResult, hyp: tuple) -> FitResult:
    """``hyp`` fitted as the diagnosis fits a hypothesis it names: a tone-side part on the
    tones, its field carried to the gates under either phase-sign convention
    (:func:`~dpdfit.analyses.diagnosis.fitting.phase_sign.carry`) and the gate side --
    nuisances and gate-side effects -- fitted there; a gate-side hypothesis on the
    gates, the tones held at the baseline's."""
    tone_hyp = tuple(h for h in hyp if EFFECTS[h[0]].side == "tones")
    if prob.gate is None or not tone_hyp:
        return fit_hypothesis(prob, hyp, fixed=_held(prob, base, [e for e, _ in hyp]),
                              init=base.nuisances)
    # a gate-side effect fitted under the baseline's field while the tones carry another
    # (or the field carried under the baseline's phase sign only) is a model the
    # diagnosis never names: its chi2 would separate the pair by the field, not the physics
    t = fit_hypothesis(prob, tone_hyp, fixed=_held(prob, base, [e for e, _ in tone_hyp]),
                       init=base.nuisances)
    ordered = tone_hyp + tuple(h for h in hyp if h not in tone_hyp)
    t = dataclasses.replace(t, effect="+".join(e for e, _ in ordered),
                            forms=tuple(f for _, f in ordered))
    return carry(prob, base, t)


def refit_chi2s(prob, base: FitResult, labels: list) -> list:
    """``[refit_label(prob, base, label) for label in labels]`` over the cores."""
    return map_over_problem(prob, refit_label, [((base, lab), {}) for lab in labels])


def refit_labels(prob, base: FitResult, labels: list) -> list:
    """Each hypothesis of ``labels`` refitted (:func:`refit_label`): ``{**label, "chi2"}``.
    A hypothesis this campaign cannot fit (a form its recordings no longer support, an
    effect not in the catalog) gets ``chi2`` None and the ``reason``: the caller compares
    nothing for it, and the diagnosis itself stands."""
    # independent fits: over the cores (each a fit from scratch, seconds each)
    done = map_over_problem(prob, _refit_or_reason, [((base, lab), {}) for lab in labels])
    return [{**lab, **res} for lab, res in zip(labels, done)]


def _refit_or_reason(prob, base: FitResult, label: dict) -> dict:
    try:
        return {"chi2": refit_label(prob, base, label)}
    except (KeyError, ValueError) as exc:
        return {"chi2": None,
                "reason": f"not fitted on this campaign ({type(exc).__name__}: {exc})"}


def _gap_change(before: dict, after: dict) -> float | None:
    try:
        g0 = float(before["rival"]) - float(before["truth"])
        g1 = float(after["rival"]) - float(after["truth"])
    except (KeyError, TypeError, ValueError, OverflowError):
        return None
    return g1 - g0


def achieved_separation(before: dict, after: dict) -> float | None:
    """``|gap_after - gap_before|``, ``gap`` the rival's chi2 minus the truth's, from two
    ``{"truth": chi2, "rival": chi2}`` (None when one is missing)."""
    d = _gap_change(before, after)
    return None if d is None else abs(d)


def separation_direction(before: dict, after: dict) -> str | None:
    """The side of the pair the recording moved toward: ``"truth"`` when the rival's
    chi2 grew against the truth's (the gap widened), ``"rival"`` when it shrank, None
    when it did not move or a chi2 is missing."""
    d = _gap_change(before, after)
    if d is None or d == 0:
        return None
    return "truth" if d > 0 else "rival"


def _binding(proposal) -> dict:
    b = proposal.get("binding") if isinstance(proposal, dict) else None
    return b if isinstance(b, dict) else {}


def binding_refits(proposal: dict | None) -> list | None:
    """The binding pair of a proposal (``next_measurement``: the hypotheses whose
    separation it predicts) as the ``refit`` list a later diagnosis is given,
    ``[truth, rival]`` each ``{"effects", "forms"}``; None without a pair."""
    b = _binding(proposal)
    if not all(isinstance(b.get(r), dict) and b[r] for r in _SIDES):
        return None
    return [{k: b[r].get(k) for k in ("effects", "forms")} for r in _SIDES]


def binding_chi2(proposal: dict | None) -> dict | None:
    """``{"truth": chi2, "rival": chi2}`` of a proposal's binding pair on the recordings
    it was proposed from (None when the proposal does not carry both)."""
    b = _binding(proposal)
    try:
        return {r: float(b[r]["chi2"]) for r in _SIDES}
    except (KeyError, TypeError, ValueError, OverflowError):
        return None


def _same_label(a: dict, b: dict) -> bool:
    return (list(a.get("effects") or []) == list(b.get("effects") or [])
            and list(a.get("forms") or []) == list(b.get("forms") or []))


def refitted_chi2(proposal: dict | None, refits: list | None) -> dict | None:
    """``{"truth": chi2, "rival": chi2}`` of a proposal's binding pair refitted by a later
    diagnosis: the entries of its ``refits`` (``extra["refits"]``) with the same effects
    and forms; None when the pair was not refitted."""
    labels = binding_refits(proposal)
    if labels is None or not refits:
        return None
    out = {}
    for side, label in zip(_SIDES, labels):
        hit = next((r for r in refits if isinstance(r, dict) and _same_label(r, label)
                    and r.get("chi2") is not None), None)
        if hit is None:
            return None
        out[side] = float(hit["chi2"])
    return out
