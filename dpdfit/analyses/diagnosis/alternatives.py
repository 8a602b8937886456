"""Which hypotheses the recordings do not separate from the named effects.

The diagnosis names the best hypothesis; this module lists every other one
still *within reach* of it once the evidence is judged against the misfit the
forms leave (:mod:`~dpdfit.analyses.diagnosis.tempering`):

* a **swap**: another single effect that is itself decisive against the
  baseline (tempered) and whose tempered BIC is within ``BIC_DECISIVE`` of the
  named one's -- "stale_calibration, or detector_nonlinearity: these
  recordings do not separate them"; and, at each step of the forward
  selection, another candidate within ``BIC_DECISIVE`` (tempered) of the one
  added;
* an **addition**: a further effect that the raw likelihood would have
  added (decisive before tempering) and that the tempered evidence still
  favours strongly (tempered delta BIC at most ``-ADDITION_IN_REACH``), but not
  decisively -- "perhaps also spam_offset".

Each alternative is a dict: ``effect`` (the candidate), ``delta_bic`` (its BIC
minus the named hypothesis's, raw: > 0 is worse; for an addition, the BIC of
the named ones plus it minus theirs), ``delta_bic_tempered`` (the same with
the chi2 difference divided by the dispersion of the evidence), ``tempering``
(that dispersion, ``tau``), ``replaces`` (the named effect it would replace,
None for an addition) and ``named`` (the complete set of effects the
alternative stands for).
"""

from __future__ import annotations

import dataclasses
import logging

import numpy as np

from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.analyses.diagnosis.families import NOISE_Z, separation_z
from dpdfit.analyses.diagnosis.tempering import tempered_gap
from dpdfit.analyses.diagnosis.verdict import ALPHA, BIC_DECISIVE, decisive

#: an addition the raw likelihood would make but the tempered evidence does not decide is
#: in reach while its chi2 gain, divided by the dispersion of the evidence, is at least
#: this (the decisive threshold with its parameters free: a parameter count alone never
#: puts a family out of reach); the simpler named set is the default
ADDITION_IN_REACH = BIC_DECISIVE

__all__ = ["ADDITION_IN_REACH", "FORM_IN_REACH", "swap_alternatives",
           "addition_alternatives", "alternatives_sentence", "shifted_hypothesis",
           "forms_in_reach", "propose", "POORLY_CONSTRAINED"]

log = logging.getLogger(__name__)


def _entry(effect, raw, gap_t, tau, replaces, named, z=None, room=None) -> dict:
    out = {"effect": effect, "delta_bic": float(raw), "delta_bic_tempered": float(gap_t),
           "tempering": float(tau), "replaces": replaces, "named": list(named)}
    if z is not None:
        out["separation_sigma"] = float(z)
    if room is not None:
        out["room"] = room
    return out


#: the observables of each side, by key prefix
_SIDE_PREFIXES = {"tones": ("tones:", "runs:"), "gates": ("gates:", "time_scan:")}


def _shared_prefixes(a, b) -> tuple | None:
    """The observables on which two single-effect fits can be compared: both sides when
    both were predicted there alike; the tone side when both act on the tones and only
    one had its field carried to the gates (the other's gates are the baseline's)."""
    sides = {getattr(EFFECTS.get(e), "side", None) for e in a.effects + b.effects}
    if sides == {"tones"}:
        return _SIDE_PREFIXES["tones"]
    return None


def swap_alternatives(fits: dict, form_fits: dict, ranking: list, first: str,
                      named: list, sides: set | None, exclude=()) -> list:
    """Families the recordings do not separate from the first named one (module doc):
    ``fits`` the single effects' fits by name (the best form, carried to the gates where
    it was), ``form_fits`` every form's fit, ``ranking`` their ranking entries (with
    their family evidence).  A family is in reach when it is itself decisive against
    the baseline (its family evidence, tempered) and either its family evidence is
    within ``BIC_DECISIVE`` of the named one's or one of its forms is within the noise
    of the named fit (:func:`~dpdfit.analyses.diagnosis.families.separation_z` below
    :data:`~dpdfit.analyses.diagnosis.families.NOISE_Z`): a parameter count alone
    never puts a family out of reach.  ``exclude``: families already given as complete
    explanations of their own.  Returns ``[(alternative dict, its fit)]``."""
    out = []
    n_tests = len(ranking)
    by_name = {r["effect"]: r for r in ranking}
    ref = by_name.get(first, {})
    for r in ranking:
        e = r["effect"]
        if e == first or e in named or "+" in e or e not in fits or e in exclude:
            continue
        if sides is not None and r["side"] not in sides:
            continue
        if not decisive(r, n_tests):
            continue
        raw, gap_t, tau = tempered_gap(fits[e], fits[first])
        fam_gap = (r.get("family_delta_bic_tempered", -gap_t)
                   - ref.get("family_delta_bic_tempered", 0.0))
        forms = {**form_fits.get(e, {}), fits[e].forms[0]: fits[e]}
        zs = {f: separation_z(fits[first], ff, _shared_prefixes(fits[first], ff))
              for f, ff in forms.items()}
        z = min(zs.values())
        if fam_gap < BIC_DECISIVE or z < NOISE_Z:
            best = min(zs, key=zs.get)
            out.append((_entry(e, raw, gap_t, tau, first,
                               [e] + [x for x in named if x != first], z=z),
                        forms[best] if z < NOISE_Z else fits[e]))
    return out


def addition_alternatives(steps: list, named: list, open_sides=()) -> list:
    """Alternatives from the forward selection's steps
    (:func:`~dpdfit.analyses.diagnosis.selection.add_effects`): ``steps`` is a list of
    ``(entries, added, refused)`` per step, ``entries`` the ``(ranking entry, fit)`` of
    each candidate tried (against the named effects before the step), ``added`` the fit
    added at that step or None, ``refused`` the ``(entry, fit, room)`` of candidates
    decisive against the named model that a form of a named family leaves no room for
    (module doc).  ``open_sides``: the sides on which the named model still shows a
    mismatch; there an addition the raw likelihood would make stays in reach whatever
    its tempering, since the misfit that tempers it is itself unexplained.  Returns
    ``[(alternative dict, its fit)]``."""
    out = []
    for step in steps:
        entries, added = step[0], step[1]
        refused = step[2] if len(step) > 2 else []
        n = len(entries)
        for entry, f, room in refused:
            c = f.effects[-1]
            out.append((_entry(c, entry["delta_bic"], entry["delta_bic_tempered"],
                               entry.get("tempering", 1.0), None, list(named) + [c],
                               room={"family": room["family"], "form": room["form"],
                                     "delta_bic_tempered": room.get(
                                         "family_delta_bic_tempered",
                                         room["delta_bic_tempered"])}), f))
        if added is None:
            listed = {f.effects[-1] for _, f, _ in refused}
            for entry, f in entries:
                c = f.effects[-1]
                gain_t = entry["delta_chi2"] / max(entry.get("tempering", 1.0), 1.0)
                open_side = getattr(EFFECTS.get(c), "side", None) in open_sides
                if (c not in listed and entry["delta_bic"] < -BIC_DECISIVE
                        and entry["p_value"] * n < ALPHA
                        and (gain_t >= ADDITION_IN_REACH or open_side)):
                    out.append((_entry(c, entry["delta_bic"], entry["delta_bic_tempered"],
                                       entry.get("tempering", 1.0), None, list(named) + [c]),
                                f))
            continue
        a = added.effects[-1]
        for entry, f in entries:
            c = f.effects[-1]
            if f is added or c in named or not decisive(entry, n):
                continue
            raw, gap_t, tau = tempered_gap(f, added)
            z = separation_z(added, f)
            if gap_t < BIC_DECISIVE or z < NOISE_Z:
                out.append((_entry(c, raw, gap_t, tau, a,
                                   [c if x == a else x for x in named], z=z), f))
    return out


#: a named effect's main size is poorly constrained when its error exceeds this fraction
#: of its value: the next measurement is then the one that pins it down best
POORLY_CONSTRAINED = 0.5


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


#: a form of a hypothesis's family is still in reach (and must be separated by a proposed
#: recording) while its tempered evidence is within this of the family's best form
FORM_IN_REACH = BIC_DECISIVE


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
        if gap_t < FORM_IN_REACH or separation_z(fit, f, _shared_prefixes(fit, f)) < NOISE_Z:
            out.append(f)
    return out


def propose(prob, chosen, alternatives: list, named_effects: list,
            form_fits: dict | None = None) -> dict:
    """The next measurement's JSON object (:mod:`..next_measurement`) for an ambiguous
    verdict (the named fit against every alternative's fit, each with its family's forms
    in reach, :func:`forms_in_reach`) or, without alternatives, for the named effects
    whose main size is poorly constrained (the fit against the same fit with that effect
    moved by 1 sigma, parameters held)."""
    from dpdfit.analyses.diagnosis.next_measurement import propose_next_measurement
    form_fits = form_fits or {}
    # the swaps first: they are the competing explanations; additions in reach differ
    # from the verdict by a refinement, and the smallest separation would chase it
    swaps = [f for a, f in alternatives if a["replaces"] is not None]
    hyps = [forms_in_reach(chosen, form_fits)] + [
        forms_in_reach(f, form_fits) for f in (swaps or [f for _, f in alternatives])]
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
        return {"what": None, "reason": "no parameter of the poorly constrained effect "
                                        "has an error to move it by"}
    tau = max([a["tempering"] for a, _ in alternatives] or [1.0])
    try:
        return propose_next_measurement(prob, hyps, tempering=tau, profile=profile).to_dict()
    except Exception as exc:          # the verdict stands whatever the proposal does
        log.warning("no next measurement could be proposed: %s", exc)
        return {"what": None, "reason": f"the menu's simulation failed: "
                                        f"{type(exc).__name__}: {exc}"}


def alternatives_sentence(verdict: str, alternatives: list) -> list[str]:
    """The report's words for the alternatives: one line per kind."""
    if not alternatives:
        return []
    lines = []
    swaps = [a for a in alternatives if a["replaces"] is not None]
    adds = [a for a in alternatives if a["replaces"] is None]
    for rep in dict.fromkeys(a["replaces"] for a in swaps):
        others = [a["effect"] for a in swaps if a["replaces"] == rep]
        lines.append(f"{rep}, or {', or '.join(others)}: these recordings do not "
                     f"separate them")
    if adds:
        lines.append(f"perhaps also {', '.join(a['effect'] for a in adds)}: these "
                     "recordings favour it, not decisively once the misfit the forms leave "
                     "is counted")
    return lines
