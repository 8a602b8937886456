"""Complete explanations, not first steps: forward selections from every first effect in
reach, compared.

Which further effects a cause needs depends on the cause: a drifted AOM changes the
optical power at gate time, a nonlinear detector does not, so the second needs a
gate-rate error the first does not.  The best single family and each family in reach
of it (a swap, :func:`~dpdfit.analyses.diagnosis.decisions.alternatives.swap_alternatives`)
therefore each start a forward selection
(:func:`~dpdfit.analyses.diagnosis.decisions.additions.select_from`; a tone-side start has its
field carried to the gates first, :func:`~dpdfit.analyses.diagnosis.fitting.phase_sign.carry`),
the complete sets are compared directly (:func:`better`), and the others in reach of
the best are its alternatives (:func:`start_alternatives`).
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.decisions.additions import select_from
from dpdfit.analyses.diagnosis.decisions.alternatives import (alternative_entry,
                                                              swap_alternatives)
from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.analyses.diagnosis.evidence.families import chi2_gap_z
from dpdfit.analyses.diagnosis.evidence.mismatches import locate_mismatches, side_evidence
from dpdfit.analyses.diagnosis.evidence.tempering import tempered_gap
from dpdfit.analyses.diagnosis.evidence.thresholds import BIC_DECISIVE, NOISE_Z
from dpdfit.analyses.diagnosis.fitting.fit_result import FitResult
from dpdfit.analyses.diagnosis.fitting.phase_sign import carry

__all__ = ["MAX_STARTS", "select", "better", "start_alternatives", "open_sides"]

#: at most this many first effects are each completed by a forward selection: the best
#: single family and the swaps in reach of it
MAX_STARTS = 3


def select(prob, base: FitResult, first: str, fits: dict, form_fits: dict,
            ranking: list, pairs: int, sides: set):
    """Complete explanations, not first steps: the best single family and each family in
    reach of it (a swap, :func:`~dpdfit.analyses.diagnosis.decisions.alternatives.swap_alternatives`)
    start a forward selection each (:func:`~dpdfit.analyses.diagnosis.decisions.additions.select_from`;
    a tone-side start has its field carried to the gates first, :func:`carry`).  The
    selection whose set has the largest gain
    (:func:`~dpdfit.analyses.diagnosis.decisions.additions.set_gain`) is the verdict's, and the
    problem is left on its models.  Returns ``(selection, the other selections)``."""
    starts = [first]
    if pairs > 0:
        swaps = swap_alternatives(fits, form_fits, ranking, first, [first], sides)
        starts += [a["effect"] for a, _ in swaps][:MAX_STARTS - 1]
    carried = getattr(prob, "carried", None) or {}
    runs = []
    for name in starts:
        if (name not in carried and prob.gate is not None
                and EFFECTS[name].side == "tones"):
            fits[name] = carry(prob, base, fits[name])
        runs.append(select_from(prob, base, fits[name], fits, form_fits, ranking, pairs,
                                sides))
    best = runs[0]
    for r in runs[1:]:
        # compared directly (the misfit of the better of the two tempers the gap), each
        # family paying for its form as in set_gain
        if better(prob, r, best):
            best = r
    prob.use_tone(best.models[0])
    prob.gate = best.models[1]
    return best, [r for r in runs if r is not best]


def open_sides(prob, chosen, sides: set) -> set:
    """The sides on which the named model still shows a mismatch (a located interval, or
    that side's chi2), among those that showed one before any effect."""
    if chosen is None:
        return set()
    return side_evidence(chosen, locate_mismatches(prob, chosen.all_params), []) & sides


def better(prob, a, b) -> bool:
    """Whether selection ``a``'s set beats ``b``'s: the tempered BIC gap between their
    fits with each family's ``2 ln F`` for its form."""
    def cost(f):
        return sum(2 * np.log(max(len(prob.forms_of(e)), 1)) for e in f.effects)
    gap = tempered_gap(b.chosen, a.chosen)[1] + cost(b.chosen) - cost(a.chosen)
    return gap > 0


def start_alternatives(prob, base: FitResult, chosen: FitResult, others: list,
                        named: list) -> list:
    """The complete explanations from other first effects still in reach of the named
    set: the gap of their gains (:func:`~dpdfit.analyses.diagnosis.decisions.additions.set_gain`)
    below ``BIC_DECISIVE``, or within the noise of the named fit
    (:func:`~dpdfit.analyses.diagnosis.evidence.families.chi2_gap_z`)."""
    out = []
    for o in others:
        if sorted(o.chosen.effects) == sorted(named):
            continue
        z = chi2_gap_z(chosen, o.chosen)
        raw, gap_t, tau = tempered_gap(o.chosen, chosen)
        if gap_t < BIC_DECISIVE or z < NOISE_Z:
            out.append((alternative_entry(o.start, raw, gap_t, tau, named[0], list(o.chosen.effects),
                               z=z), o.chosen))
    return out
