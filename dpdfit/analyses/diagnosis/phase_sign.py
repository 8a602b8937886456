"""A tone-side effect's fit carried over to the gates, under both phase-sign conventions.

The sign convention of a lab's recorded phase response is a discrete nuisance
of every hypothesis: the tone powers do not depend on it (red and blue swap),
the gates do.  The problem chooses it for the baseline
(:meth:`~dpdfit.analyses.diagnosis.problem.Problem`); a tone-side effect that
also changes the gates can mislead that choice, so the best tone-side effect
is re-predicted on the gates under both signs (:func:`repredict_gates`), and
an effect whose spectra themselves depend on the sign (``sign_sensitive``,
the AOM memory) is refitted under the other one (:func:`refit_other_sign`).
"""

from __future__ import annotations

import dataclasses

from dpdfit.analyses.diagnosis.effects import (PHASE_ODD_PARAMS, TONE_PARAMS, effect_form,
                                              form_key)
from dpdfit.analyses.diagnosis.fitting import FitResult, fit_hypothesis
from dpdfit.analyses.diagnosis.gate_model import GateModel

__all__ = ["repredict_gates", "refit_other_sign"]


def repredict_gates(prob, f: FitResult) -> FitResult:
    """A tone-side effect's fit with the gates re-predicted from its field and refitted.

    The tone parameters are held at their fit; the gate nuisances are refitted.  The
    sign convention of the phase response is chosen again here (the tone powers do not
    depend on it, the gates do): both the current sign and the other one (the whole
    AM-to-PM, the effect's phase-odd parameters included, sign-flipped) are tried unless
    the effect's spectra depend on the sign (``sign_sensitive``: the AOM memory), and the
    better gate fit is kept.
    """
    held = {k: v for k, v in {**f.nuisances, **f.params}.items()
            if k in prob.tone_nuisances or k in TONE_PARAMS}
    options = [(prob.tone, held)]
    pm = [k for k in PHASE_ODD_PARAMS if k in held]
    sensitive = effect_form(form_key(f.effect, f.variant)).sign_sensitive
    if not sensitive and (prob.camp.phase is not None or pm):
        other = {**held, **{k: -held[k] for k in pm}}
        options.append((prob.tone.with_phase_sign(-prob.tone.phase_sign), other))
    saved = prob.gate
    best, best_sign = None, None
    with prob.swapped_models():
        for tone, p in options:
            prob.gate = saved.rebased(tone, p)
            g = fit_hypothesis(prob, (), fixed=p)
            if best is None or g.chi2 < best.chi2:
                best, best_sign = g, (tone.phase_sign, {k: p[k] for k in pm})
    params = {**f.params, **{k: v for k, v in best_sign[1].items() if k in f.params}}
    return dataclasses.replace(
        best, effect=f.effect, variant=f.variant, params=params, params_err=f.params_err,
        nuisances={**{k: v for k, v in best.nuisances.items() if k not in f.params},
                   "phase_sign": best_sign[0]},
        n_par=f.n_par)


def refit_other_sign(prob, f: FitResult, gate_nuis: dict, init: dict) -> FitResult:
    """A sign-sensitive (memory) effect refitted under the other phase-sign convention.

    The sign was chosen by the gates *before* any effect; an effect that also spoils
    the gates can mislead that choice.  For most effects the tone powers do not
    depend on the sign and :func:`repredict_gates` re-chooses it; a memory kernel's
    spectra do, so here the effect is refitted to the tones under the other sign
    (``gate_nuis`` held, nuisances started from ``init``), its gates re-predicted,
    and the better total chi2 kept (the sign is a discrete nuisance of every
    hypothesis).
    """
    key = form_key(f.effect, f.variant)
    saved_gate = prob.gate
    alt = prob.tone.with_phase_sign(-prob.tone.phase_sign)
    with prob.swapped_models():
        prob.use_tone(alt)
        # the gate engine's baseline *and* responses for this sign (responses of the
        # other sign's field put the contrast off by tens of sigma)
        prob.gate = GateModel(prob.camp, alt, saved_gate.sig_jit, responses=True)
        prob.set_rate_scatter(saved_gate.rate_rel)
        g = fit_hypothesis(prob, (key,), starts=[f.params], fixed=gate_nuis, init=init)
        g = repredict_gates(prob, dataclasses.replace(g, variant=f.variant))
    return g if g.chi2 < f.chi2 else f
