"""What the next recording must separate, and the proposal: the named fit against the
strongest open alternative's
(:func:`~dpdfit.analyses.diagnosis.decisions.alternatives.strongest_alternative`), each
with its family's forms in reach (:func:`forms_in_reach`), or,
without alternatives, a poorly constrained size against the same fit moved by 1 sigma
(:func:`shifted_hypothesis`); :func:`propose` hands them to
:func:`~dpdfit.analyses.diagnosis.proposal.next_measurement.propose_next_measurement`."""

from __future__ import annotations

import dataclasses
import logging

import numpy as np

from dpdfit.analyses.diagnosis.decisions.alternatives import strongest_alternative
from dpdfit.analyses.diagnosis.evidence.families import chi2_gap_z, shared_observables
from dpdfit.analyses.diagnosis.evidence.tempering import tempered_gap
from dpdfit.analyses.diagnosis.evidence.thresholds import FORM_IN_REACH, NOISE_Z
from dpdfit.analyses.diagnosis.proposal.next_measurement import (NextMeasurement,
                                                                 propose_next_measurement)

__all__ = ['shifted_hypothesis', 'forms_in_reach', 'propose']


log = logging.getLogger(__name__)


def shifted_hypothesis(fit, name: str):
    """``fit`` with effect ``name``'s free parameters moved by their 1-sigma errors away
    from zero: the hypothesis a measurement pinning its size down must separate."""
    moved = {}
    for k, v in fit.params.items():
        err = fit.params_err.get(k, float("nan"))
        if k.startswith(name + ".") and k in fit.free and np.isfinite(err) and err > 0:
            moved[k] = v + np.copysign(err, v if v != 0 else 1.0)
    if not moved:
        return None
    return dataclasses.replace(fit, params={**fit.params, **moved})


def forms_in_reach(fit, form_fits: dict) -> list:
    """``fit`` and, for a single effect, its family's other forms the recordings do not
    exclude (tempered delta BIC within :data:`FORM_IN_REACH` of the best form, or within
    the noise of ``fit``): the forms a proposed recording must separate."""
    out = [fit]
    if len(fit.effects) != 1:
        return out
    forms = form_fits.get(fit.effects[0], {})
    if not forms:
        return out
    best = min(forms.values(), key=lambda f: f.bic)
    for name, f in forms.items():
        if name in fit.forms:
            continue
        gap_t = 0.0 if f is best else tempered_gap(f, best)[1]
        if gap_t < FORM_IN_REACH or chi2_gap_z(fit, f, shared_observables(fit, f)) < NOISE_Z:
            out.append(f)
    return out


def propose(prob, chosen, alternatives: list, named_effects: list,
            form_fits: dict | None = None) -> NextMeasurement:
    """The next measurement
    (:class:`~dpdfit.analyses.diagnosis.proposal.next_measurement.NextMeasurement`) for an
    ambiguous verdict (the named fit against the fit of the strongest of the open
    ``alternatives``, ``[(Alternative, fit)]``, each with its family's forms in reach,
    :func:`forms_in_reach`) or, without alternatives, for the named effects
    whose main size is poorly constrained (the fit against the same fit with that effect
    moved by 1 sigma, parameters held)."""
    form_fits = form_fits or {}
    # aimed at the strongest rival: the open alternatives have support of their own (an
    # addition the recordings do not see is an upper limit, not among them), and the
    # weakest-separated of several would chase the one with the least
    rival = strongest_alternative(alternatives)
    hyps = [forms_in_reach(chosen, form_fits)] + (
        [] if rival is None else [forms_in_reach(rival[1], form_fits)])
    profile = True
    if len(hyps) == 1:
        for e in named_effects:
            if e.get("poorly_constrained"):
                alt = shifted_hypothesis(chosen, e["effect"])
                if alt is not None:
                    hyps = [[chosen], [alt]]
                    profile = False
                    break
    if len(hyps) == 1:
        return NextMeasurement(None, reason="no parameter of the poorly constrained effect "
                                            "has an error to move it by")
    tau = 1.0 if rival is None else rival[0].tempering
    try:
        return propose_next_measurement(prob, hyps, tempering=tau, profile=profile)
    except Exception as exc:          # the verdict stands whatever the proposal does
        log.warning("no next measurement could be proposed: %s", exc)
        return NextMeasurement(None, reason=f"the menu's simulation failed: "
                                            f"{type(exc).__name__}: {exc}")
