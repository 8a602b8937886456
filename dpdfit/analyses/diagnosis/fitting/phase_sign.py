"""A tone-side effect's fit carried over to the gates, under both phase-sign conventions.

The sign convention of a lab's recorded phase response is a discrete nuisance
of every hypothesis: the tone powers of a memoryless field do not depend on
it (red and blue swap), the gates do.  The problem chooses it for the baseline
(:class:`~dpdfit.analyses.diagnosis.model.residuals.Problem`); a tone-side effect that
also changes the gates can mislead that choice, so the tone-side effects of a
fit are re-predicted on the gates under both signs (:func:`repredict_gates`),
and an effect whose spectra themselves depend on the sign (``sign_sensitive``,
the AOM memory) is refitted under the other one (:func:`refit_other_sign`).
"""

from __future__ import annotations

import dataclasses

from dpdfit.analyses.diagnosis.effects import EFFECTS, effect_of_key
from dpdfit.analyses.diagnosis.fitting.fit_result import FitResult, combine_sides
from dpdfit.analyses.diagnosis.fitting.hypothesis_fit import fit_hypothesis
from dpdfit.analyses.diagnosis.model.gates.gate_model import GateModel

__all__ = ["repredict_gates", "refit_other_sign", "tone_held", "carry"]


def _phase_odd(p: dict) -> list:
    return [k for k in p if (e := effect_of_key(k)) is not None
            and k.split(".", 1)[1] in e.phase_odd]


def tone_held(prob, f: FitResult) -> dict:
    """The tone side of fit ``f``: its tone nuisances and tone-side effect parameters."""
    out = {}
    for k, v in f.all_params.items():
        e = effect_of_key(k)
        if (k in prob.tone_nuisances) if e is None else e.side == "tones":
            out[k] = v
    return out


def repredict_gates(prob, f: FitResult, keep_sign: bool = False) -> FitResult:
    """Fit ``f`` with the gates re-predicted from its field and refitted.

    The tone parameters are held at their fit; the gate nuisances and gate-side
    effects are refitted.  The sign convention of the phase response is chosen again
    here: both the current sign and the other one (the whole AM-to-PM, the effects'
    phase-odd parameters included, sign-flipped) are tried unless an effect's spectra
    depend on the sign (``sign_sensitive``) or ``keep_sign``, and the better gate fit is
    kept.  The gate model stays rebased on that field (``prob.gate``), so that effects
    added later see it.
    """
    held = tone_held(prob, f)
    options = [(prob.tone, held)]
    pm = _phase_odd(held)
    sensitive = any(EFFECTS[e].sign_sensitive for e in f.effects if EFFECTS[e].side == "tones")
    if not (sensitive or keep_sign) and (prob.camp.phase is not None or pm):
        other = {**held, **{k: -held[k] for k in pm}}
        options.append((prob.tone.with_phase_sign(-prob.tone.phase_sign), other))
    saved = prob.gate
    gate_hyp = tuple((e, form) for e, form in f.hypothesis if EFFECTS[e].side == "gates")
    best, best_opt = None, None
    for tone, p in options:
        prob.gate = saved.rebased(tone, p)
        prob.use_tone(tone)
        g = fit_hypothesis(prob, gate_hyp, fixed=p, init=f.all_params)
        if best is None or g.chi2 < best.chi2:
            best, best_opt = g, (tone, p, prob.gate)
    tone, p, gate = best_opt
    prob.use_tone(tone)
    prob.gate = gate
    flip = {k: p[k] for k in pm}
    f_tone = dataclasses.replace(f, params={**f.params, **{k: v for k, v in flip.items()
                                                           if k in f.params}})
    out = combine_sides(prob, best, f_tone, "tones", hyp=f.hypothesis)
    return dataclasses.replace(out, nuisances={**out.nuisances,
                                               "phase_sign": tone.phase_sign})


def refit_other_sign(prob, f: FitResult, gate_nuis: dict, init: dict) -> FitResult:
    """A sign-sensitive (memory) effect refitted under the other phase-sign convention.

    The sign was chosen by the gates *before* any effect; an effect that also spoils
    the gates can mislead that choice.  For most effects the tone powers do not
    depend on the sign and :func:`repredict_gates` re-chooses it; a memory's spectra
    do, so here the effect is refitted to the tones under the other sign
    (``gate_nuis`` held, nuisances started from ``init``), its gates re-predicted,
    and the better total chi2 kept (the sign is a discrete nuisance of every
    hypothesis).  Leaves ``prob`` with the models of the kept sign.
    """
    saved = prob.tone, prob.gate, dict(prob.prior)
    alt = prob.tone.with_phase_sign(-prob.tone.phase_sign)
    prob.use_tone(alt)
    # the gate engine's baseline *and* responses for this sign (responses of the
    # other sign's field put the contrast off by tens of sigma)
    prob.gate = GateModel(prob.camp, alt, saved[1].sig_jit, effects=prob.effects,
                          responses=True)
    prob.set_rate_scatter(saved[1].rate_rel)
    flipped = {k: -v if k in _phase_odd(f.params) else v for k, v in f.params.items()}
    g = fit_hypothesis(prob, f.hypothesis, starts=[flipped], fixed=gate_nuis, init=init)
    g = repredict_gates(prob, g, keep_sign=True)
    if g.chi2 < f.chi2:
        return g
    prob.use_tone(saved[0])
    prob.gate, prob.prior = saved[1], saved[2]
    return f


def carry(prob, base: FitResult, f: FitResult) -> FitResult:
    """Tone-side fit ``f`` with its gates re-predicted from its field and refitted (tone
    parameters held at their fit), under the other phase sign too (refitted there when
    its spectra depend on the sign).  The problem's models are left as they were; the
    field's are kept in ``prob.carried`` under the effect's name, for the forward
    selection that starts from it
    (:func:`~dpdfit.analyses.diagnosis.decisions.additions.use_field_of`)."""
    name = f.effects[0]
    saved = prob.tone, prob.gate
    f = repredict_gates(prob, f)
    if prob.camp.phase is not None and EFFECTS[name].sign_sensitive:
        f = refit_other_sign(prob, f, {k: v for k, v in base.nuisances.items()
                                                if k not in prob.tone_nuisances and k != "phase_sign"}, base.nuisances)
    prob.carried = {**(getattr(prob, "carried", None) or {}), name: (prob.tone, prob.gate)}
    prob.use_tone(saved[0])
    prob.gate = saved[1]
    return f
