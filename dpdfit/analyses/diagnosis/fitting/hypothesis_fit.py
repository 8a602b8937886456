"""The fit of one hypothesis (the baseline, an effect or a pair) to every observable.

:func:`fit_hypothesis` fits the nuisances plus the effects' parameters by
``scipy.optimize.least_squares`` (:mod:`dpdfit.analyses.diagnosis.fitting.least_squares`:
starting points and the solution with the calibration modes profiled out
linearly) and states the result (:func:`_result`: Gauss-Newton errors, the
effects' sizes, chi2 per observable).

Parameter errors are the Gauss-Newton ones, ``(J^T J)^-1`` of the standardised
residuals at the optimum (1 sigma), with the calibration's error modes profiled
out, so they include the calibration uncertainty; ``params_err`` is NaN when a
parameter sits at its bound.
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.effects import get
from dpdfit.analyses.diagnosis.fitting.fit_result import FitResult, make_result
from dpdfit.analyses.diagnosis.fitting.least_squares import (MAX_NFEV, Objective,
                                                             best_solution, initial_point,
                                                             starting_points)
from dpdfit.core.parallel import pmap

__all__ = ['fit_hypothesis', 'fit_effect', 'fit_all', 'fit_effects', 'form_chains',
           'map_over_problem']


def _result(obj: Objective, best, best_lin) -> FitResult:
    """The :class:`FitResult` of the solution ``best`` (modes profiled at ``best_lin``)."""
    x = best.x
    J = best.jac
    try:
        cov = np.linalg.pinv(J.T @ J)
    except np.linalg.LinAlgError:
        cov = np.full((x.size, x.size), np.nan)
    p = {**obj.params(x), **obj.modes_at(best_lin, x)}
    fixed_eff = {k: float(v) for k, v in obj.fixed.items() if "." in k}
    return make_result(obj.prob, [(e.name, f.name) for e, f in obj.forms], p, obj.eff_params,
                       fixed_eff, cov, obj.parameters.at_optimum(x), obj.n_replaced)


def fit_hypothesis(prob, hyp: tuple = (), starts=None, fixed: dict | None = None,
                   init: dict | None = None, max_nfev: int = MAX_NFEV) -> FitResult:
    """Least-squares fit of the nuisances plus the effects' parameters.

    ``hyp``: ``((effect name, form name or None), ...)``; empty: the baseline.
    ``fixed`` holds nuisances (or effect parameters) at given values: the tone and
    gate sides of the model share no parameter, so an effect on one side is
    fitted with the other side's nuisances held at their baseline optimum,
    which is exact and saves the other side's model evaluations.  ``init``:
    starting values of nuisances and effect parameters; ``starts``: further
    starting points (dicts).  The calibration modes that are not held are
    profiled out linearly (:class:`ModeProfile`), linearised first at the prior
    centre of the modes (an effect that explains the recordings leaves them
    near it), then at the optimum.
    """
    fixed = dict(fixed or {})
    init = dict(init or {})
    hyp = tuple((n, f) if isinstance(n, str) else tuple(n) for n, f in hyp)
    obj = Objective(prob, hyp, fixed)
    d_init = {k: 0.0 for k in obj.prof}
    x0, far = initial_point(obj, init)
    lin0 = obj.linearise(x0, d_init)
    candidates = starting_points(obj, obj.forms, x0, far, starts, lin0)
    best, best_lin = best_solution(obj, candidates, lin0, d_init, max_nfev)
    return _result(obj, best, best_lin)


def form_chains(prob, name: str) -> list:
    """Effect ``name``'s forms the campaign supports, grouped into chains: a form
    that starts from a smaller one's optimum (``starts_from``) follows it; independent
    chains can be fitted in parallel."""
    forms = list(prob.forms_of(name))
    names = {f.name for f in forms}
    chains = []
    for f in forms:
        if f.starts_from in names:
            chain = next(c for c in chains if f.starts_from in c)
            chain.append(f.name)
        else:
            chains.append([f.name])
    return chains


def fit_effect(prob, name: str, fixed: dict | None = None, init: dict | None = None,
               others: tuple = (), starts: dict | None = None, forms=None) -> dict:
    """Every form the campaign supports of effect ``name`` (or those named in
    ``forms``), nested forms started from the smaller form's optimum:
    ``{form name: FitResult}``.

    ``others``: further ``(effect, form)`` pairs fitted with it (an effect added to
    named ones), their parameters started from ``starts``.
    """
    e = get(name)
    out = {}
    for form in prob.forms_of(name):
        if forms is not None and form.name not in forms:
            continue
        st = [dict(starts or {})]
        if form.starts_from in out:
            prev = out[form.starts_from]
            st = [{**prev.params, **(starts or {})}]
            st += [{**prev.params, **(starts or {}), **{e.key(k): v for k, v in x.items()}}
                   for x in form.extra_starts]
        else:
            st += [{**(starts or {}), **{e.key(k): v for k, v in x.items()}}
                   for x in form.extra_starts]
        out[form.name] = fit_hypothesis(prob, tuple(others) + ((name, form.name),),
                                        starts=st, fixed=fixed, init=init)
    return out


#: the problem the parallel fits share (set before forking: children inherit it)
_SHARED: dict = {}


def _fit_job(fn, args: tuple, kw: dict):
    return fn(_SHARED["prob"], *args, **kw)


def map_over_problem(prob, fn, jobs: list) -> list:
    """``[fn(prob, *args, **kw) for args, kw in jobs]`` over the cores: the problem is
    inherited by the forked workers, never pickled; only ``args``, ``kw`` and the
    results are (:func:`~dpdfit.core.parallel.pmap`; the same results in any order)."""
    return _pmap_prob(prob, fn, jobs)


def _pmap_prob(prob, fn, jobs: list) -> list:
    _SHARED["prob"] = prob
    try:
        return pmap(_fit_job, [((fn, a, kw), {}) for a, kw in jobs])
    finally:
        _SHARED.clear()


def fit_all(prob, jobs: list) -> list:
    """``[fit_hypothesis(prob, hyp, **kw) for hyp, kw in jobs]`` over the cores
    (fork: only the job's arguments and result are pickled; same results in any order)."""
    return _pmap_prob(prob, fit_hypothesis, [((hyp,), kw) for hyp, kw in jobs])


def fit_effects(prob, jobs: list) -> list:
    """``[fit_effect(prob, name, **kw) for name, kw in jobs]`` over the cores: each
    effect's chains of forms (:func:`form_chains`) are separate jobs, the costliest
    first (tone-side before gate-side, more forms first), so that the cores stay busy."""
    tasks = []
    for i, (name, kw) in enumerate(jobs):
        for chain in form_chains(prob, name):
            cost = (get(name).side == "tones", len(chain),
                    any(get(name).form(f, prob).seed_grid for f in chain))
            tasks.append((cost, i, name, chain, kw))
    tasks.sort(key=lambda t: t[0], reverse=True)
    done = _pmap_prob(prob, fit_effect, [((name,), {**kw, "forms": chain})
                                         for _, _, name, chain, kw in tasks])
    out = [{} for _ in jobs]
    for (_, i, name, _, _), res in zip(tasks, done):
        out[i].update(res)
    for (name, _), res in zip(jobs, out):
        order = [f.name for f in prob.forms_of(name)]
        res_sorted = {k: res[k] for k in order if k in res}
        res.clear()
        res.update(res_sorted)
    return out
