"""Profile-likelihood errors of a named effect's parameters where the curvature fails.

The Gauss-Newton error of a parameter is the curvature of chi2 at the optimum;
at a bound (a rate fitted at 0, a common-mode fraction at 1) it does not
exist.  There the parameter is profiled: held at trial values stepping away
from the bound, every other parameter refitted (:func:`~dpdfit.analyses.diagnosis.fitting.hypothesis_fit.fit_hypothesis`),
until chi2 has risen by ``DELTA_CHI2`` (1: a 68 % interval for one parameter);
the crossing is bisected.  The effect's sizes then carry the profile's
one-sided interval of that parameter (``method`` "profile"), combined in
quadrature with the delta-method error of the others.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.analyses.diagnosis.fitting.fit_result import FitResult
from dpdfit.analyses.diagnosis.fitting.hypothesis_fit import fit_hypothesis

__all__ = ["profile_errors", "profile_interval", "DELTA_CHI2", "PROFILE_BISECTIONS", "MAX_PROFILED", "PROFILE_DOUBLINGS"]

#: chi2 rise that ends a 1-sigma profile interval of one parameter
DELTA_CHI2 = 1.0
#: parameters profiled per effect, at most
MAX_PROFILED = 2
#: bisections of the crossing, and doublings of the step at most
PROFILE_BISECTIONS = 4
PROFILE_DOUBLINGS = 8


def _fit_with_held(prob, fit: FitResult, held: dict) -> FitResult:
    """``fit``'s hypothesis refitted with the effect parameters ``held`` fixed (the
    nuisances of a side no effect of it acts on held at ``fit``'s values)."""
    sides = {EFFECTS[e].side for e in fit.effects}
    other = {}
    if len(sides) == 1 and getattr(prob, "gate", None) is not None:
        tone = sides == {"tones"}
        other = {k: v for k, v in fit.nuisances.items()
                 if k in prob.prior and (k in prob.tone_nuisances) != tone}
    return fit_hypothesis(prob, fit.hypothesis, fixed={**other, **held},
                          init=fit.all_params, starts=[fit.params])


def profile_interval(prob, fit: FitResult, key: str) -> tuple[float, float]:
    """The 1-sigma profile interval ``(lo, hi)`` of effect parameter ``key`` of ``fit``
    (one side stays at the bound where the fit sits on it)."""
    name, par_name = key.split(".", 1)
    par = EFFECTS[name].param(par_name, prob)
    x0 = fit.params[key]
    c0 = fit.chi2
    out = []
    for direction, bound in ((-1.0, par.lo), (1.0, par.hi)):
        if abs(x0 - bound) <= 1e-9 * max(1.0, abs(bound)):
            out.append(x0)
            continue
        step = 2.0 * par.scale
        inside, outside = x0, None
        for _ in range(PROFILE_DOUBLINGS):
            x = float(np.clip(x0 + direction * step, par.lo, par.hi))
            if _fit_with_held(prob, fit, {key: x}).chi2 - c0 >= DELTA_CHI2:
                outside = x
                break
            inside = x
            if x in (par.lo, par.hi):
                break
            step *= 2
        if outside is None:
            out.append(inside)
            continue
        for _ in range(PROFILE_BISECTIONS):
            mid = 0.5 * (inside + outside)
            if _fit_with_held(prob, fit, {key: mid}).chi2 - c0 >= DELTA_CHI2:
                outside = mid
            else:
                inside = mid
        out.append(0.5 * (inside + outside))
    return out[0], out[1]


def profile_errors(prob, fit: FitResult, name: str) -> dict:
    """Effect ``name``'s sizes in ``fit`` (:class:`~dpdfit.analyses.diagnosis.effects.Size`),
    their errors from the profile where a free parameter of the effect has no
    curvature error (at a bound)."""
    e = EFFECTS[name]
    sizes = dict(fit.sizes.get(name, {}))
    poor = [k for k in fit.free if k.startswith(name + ".")
            and (k in fit.at_bound or not np.isfinite(fit.params_err.get(k, np.nan)))]
    if not poor:
        # every error has its curvature: nothing to profile (nor to evaluate the size at)
        return sizes
    # the parameters the main size depends on (a profile is a dozen refits each)
    main = e.main
    p0 = fit.all_params
    base_main = e.size_values(prob, p0).get(main, (0.0,))[0]
    poor = [k for k in poor if abs(e.size_values(prob, {**p0, k: p0[k] + 1e-3 * max(
        abs(p0[k]), e.param(k.split(".", 1)[1], prob).scale)}).get(main, (base_main,))[0]
                                   - base_main) > 0][:MAX_PROFILED]
    if not poor:
        return sizes
    p = fit.all_params
    base = e.size_values(prob, p)
    spread = {k: 0.0 for k in base}
    for key in poor:
        lo, hi = profile_interval(prob, fit, key)
        for x in (lo, hi):
            alt = e.size_values(prob, {**p, key: x})
            for k in base:
                spread[k] = max(spread[k], abs(alt[k][0] - base[k][0]))
    out = {}
    for k, s in sizes.items():
        other = s.error if np.isfinite(s.error) else 0.0
        out[k] = dataclasses.replace(s, error=float(np.hypot(other, spread.get(k, 0.0))),
                                     meaning=s.meaning + " (error: profile likelihood)")
    return out
