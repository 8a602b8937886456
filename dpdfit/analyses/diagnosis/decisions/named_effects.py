"""The named effects as the diagnosis reports them: form, parameters, sizes in a
laboratory's terms with errors that include the misfit and the form
(:mod:`~dpdfit.analyses.diagnosis.evidence.form_errors`), cost in Bell fidelity, and the chi2
each removes per observable group."""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.analyses.diagnosis.evidence.fidelity_cost import fidelity_cost
from dpdfit.analyses.diagnosis.evidence.form_errors import (form_weights, honest_cost,
                                                            honest_sizes)
from dpdfit.analyses.diagnosis.evidence.tempering import evidence_dispersion
from dpdfit.analyses.diagnosis.evidence.thresholds import POORLY_CONSTRAINED
from dpdfit.analyses.diagnosis.fitting.fit_result import FitResult
from dpdfit.analyses.diagnosis.fitting.likelihood_intervals import profile_errors

__all__ = ["named_effects", "group_chi2"]


def group_chi2(f: FitResult) -> dict:
    """Chi2 of fit ``f`` by observable group: ``{"tones": ..., "gates": ...}``."""
    groups = {"tones": ("tones:", "runs:"), "gates": ("gates:", "time_scan:")}
    return {g: sum(v for k, v in f.chi2_by_observable.items() if k.startswith(pre))
            for g, pre in groups.items()}


def named_effects(prob, base: FitResult, chosen: FitResult, named: list,
                   chain: list, form_fits: dict) -> list:
    """Each named effect: its form, parameters, sizes (profile-likelihood errors where
    the curvature error is poor; errors that include the misfit and the form,
    :mod:`~dpdfit.analyses.diagnosis.evidence.form_errors`), cost in Bell fidelity and the chi2
    it removes per observable group (against the named effects before it)."""
    out = []
    prev = [base] + chain[:-1]
    for i, name in enumerate(named):
        explains = None
        tau = 1.0
        if i < len(chain):
            a, b = group_chi2(prev[i]), group_chi2(chain[i])
            explains = {g: a[g] - b[g] for g in a}
            tau = evidence_dispersion(chain[i], prev[i])
        form = chosen.forms[chosen.effects.index(name)]
        forms = form_fits.get(name, {})
        sizes = honest_sizes(profile_errors(prob, chosen, name), name, form, forms, tau)
        costs = {f: fidelity_cost(prob, ff, name, with_error=False)[0]
                 for f, ff in forms.items()} if len(forms) > 1 else {}
        cost, cost_err, cost_form = honest_cost(fidelity_cost(prob, chosen, name), costs,
                                                form, forms, tau)
        main = sizes.get(EFFECTS[name].main)
        poor = bool(main is not None and np.isfinite(main["error"])
                    and abs(main["error"]) > POORLY_CONSTRAINED * abs(main["value"]))
        out.append({"effect": name, "form": form, "side": EFFECTS[name].side,
                    "params": chosen.params_of(name), "params_err": chosen.errors_of(name),
                    "sizes": sizes, "tempering": tau,
                    "form_weights": form_weights(forms),
                    "fidelity_cost": cost, "fidelity_cost_err": cost_err,
                    "fidelity_cost_err_form": cost_form, "poorly_constrained": poor,
                    "explains": explains, "meaning": EFFECTS[name].meaning})
    return out
