"""Errors of a named effect's sizes that include what the recordings leave open about
its form.

A size's Gauss-Newton (or profile-likelihood) error assumes the fitted form is
exactly the laboratory's physics.  It never is, and the error is too small by
as much as the form is off.  Two terms are added:

* **the misfit** -- the statistical error (curvature, or the profile where a
  parameter sits at a bound) is multiplied by ``sqrt(tau)``, ``tau`` the
  dispersion of the effect's own evidence: the chi2 difference between the
  fit without the effect and with it, compared with what an exact model
  would give, from the residuals the final model leaves along the direction
  the effect moves them (:func:`~dpdfit.analyses.diagnosis.evidence.tempering.evidence_dispersion`;
  this is a sandwich, robust, variance along that direction, and 1 when the
  model describes the recordings to their noise);
* **the form** -- the spread of the size over the effect's family forms
  fitted alone, weighted by their evidence with the same tempering
  (``w_f ~ exp(-tempered delta BIC_f / 2)`` against the best form, a
  Bayesian model average over the family): ``sqrt(sum_f w_f (s_f - s_ref)^2)``,
  ``s_ref`` the size of the named form fitted alone (so a joint fit's shift
  does not count as spread).

The reported error is ``sqrt(tau * stat^2 + form^2)``; each size's dict keeps
the parts (``error_statistical``, ``tempering``, ``error_form``).  The cost in
Bell fidelity gets its error the same way.
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.evidence.tempering import tempered_gap

__all__ = ["form_weights", "honest_sizes", "honest_cost"]


def form_weights(form_fits: dict) -> dict:
    """``{form: weight}`` of an effect's forms fitted alone, by their tempered BIC
    against the best of them (weights sum to 1)."""
    if not form_fits:
        return {}
    best = min(form_fits.values(), key=lambda f: f.bic)
    w = {}
    for name, f in form_fits.items():
        gap_t = 0.0 if f is best else tempered_gap(f, best)[1]
        w[name] = float(np.exp(-0.5 * max(gap_t, 0.0)))
    total = sum(w.values())
    return {k: v / total for k, v in w.items()}


def _spread(values: dict, weights: dict, ref) -> float:
    if ref is None or not np.isfinite(ref):
        return 0.0
    s2 = sum(weights[f] * (v - ref) ** 2 for f, v in values.items()
             if f in weights and np.isfinite(v))
    return float(np.sqrt(s2))


def honest_sizes(sizes: dict, name: str, form: str, form_fits: dict, tau: float) -> dict:
    """The named effect's sizes (``{quantity: Size}``, statistical errors) as JSON dicts
    whose ``error`` includes the misfit and the form (module doc)."""
    weights = form_weights(form_fits)
    out = {}
    for k, s in sizes.items():
        values = {f: fit.sizes.get(name, {}).get(k).value for f, fit in form_fits.items()
                  if fit.sizes.get(name, {}).get(k) is not None}
        ref = values.get(form, values.get(min(form_fits, key=lambda f: form_fits[f].bic))
                         if form_fits else None)
        spread = _spread(values, weights, ref)
        stat = s.error if np.isfinite(s.error) else float("nan")
        total = float(np.sqrt(tau * stat ** 2 + spread ** 2)) if np.isfinite(stat) else stat
        out[k] = {**s.to_dict(), "error": total, "error_statistical": stat,
                  "tempering": float(tau), "error_form": spread}
    return out


def honest_cost(cost: tuple, form_costs: dict, form: str, form_fits: dict,
                tau: float) -> tuple[float, float, float]:
    """``(cost, error, error_form)`` of the cost in Bell fidelity: its delta-method error
    times ``sqrt(tau)`` and the spread of the forms' costs (``form_costs``: ``{form:
    cost}`` of the forms fitted alone), combined as for the sizes."""
    c, err = cost
    weights = form_weights(form_fits)
    ref = form_costs.get(form)
    spread = _spread(form_costs, weights, ref)
    total = float(np.sqrt(tau * err ** 2 + spread ** 2)) if np.isfinite(err) else err
    return c, total, spread
