"""The least-squares problem of one hypothesis: its free parameters, starting points and
solution with the calibration's error modes profiled out linearly (:class:`ModeProfile`).

:func:`dpdfit.analyses.diagnosis.fitting.hypothesis_fit.fit_hypothesis` drives it: the first
starting point (:func:`initial_point`), the others (:func:`starting_points`: an
effect's seed grid, the prior centre of a nuisance pushed far out, given starts),
and the best solution over them (:func:`best_solution`, re-linearised at the
optimum until the modes settle, :func:`solve_profiled`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from dpdfit.analyses.diagnosis.effects import get
from dpdfit.analyses.diagnosis.fitting.variable_projection import ModeProfile
from dpdfit.analyses.diagnosis.model.parameters import Parameter, Parameters

__all__ = ["Objective", "Optimum", "initial_point", "starting_points", "solve_profiled",
           "best_solution", "MAX_NFEV", "FIT_TOL", "PROFILE_RELIN", "PROFILE_TOL",
           "JACOBIAN_FD_STEP", "SCREEN_NFEV", "FAR_NUISANCE"]

#: cap on residual evaluations per least-squares start
MAX_NFEV = 100
#: relative tolerances of chi2 and of the parameters that end a least-squares run: the
#: ranking needs chi2 to ~0.1 (1e-6 of the largest, ~1e5), the errors ~1 % of a sigma
FIT_TOL = 1e-6
#: calibration modes profiled out linearly (:class:`ModeProfile`): re-linearisations at
#: the optimum, and the change of the modes (sigma) that ends them
PROFILE_RELIN = 3
PROFILE_TOL = 0.05
#: finite-difference step of the fits' Jacobian, in units of each parameter's scale
JACOBIAN_FD_STEP = 1e-3
#: evaluations of the short runs that choose among several starts
SCREEN_NFEV = 10
#: a baseline nuisance further than this (prior sigmas) from its centre also gets a
#: start from the centre in the effect fits
FAR_NUISANCE = 5.0



@dataclass(frozen=True)
class Optimum:
    """Optimum of one least-squares run: parameters, cost (chi2/2), Jacobian."""

    x: np.ndarray
    cost: float
    jac: np.ndarray


def _first_form(prob, name: str):
    """The first form of ``name`` the problem keeps (None: the catalog form)."""
    forms = prob.forms_of(name) if hasattr(prob, "forms_of") else ()
    return forms[0].name if forms else None


class Objective:
    """The standardised residuals of one hypothesis over its free parameters.

    Free: every nuisance that is neither ``fixed`` nor a calibration mode
    (those are profiled, :class:`ModeProfile`) nor replaced by a form, then the
    effects' free parameters (``hyp``: ``((effect, form), ...)``), each with its
    bounds, starting value and scale (:attr:`parameters`); the forms' fixed
    parameters are held.
    """

    def __init__(self, prob, hyp: tuple, fixed: dict):
        self.prob = prob
        held = dict(fixed)          # the caller's: nuisances, or effect parameters held
        fixed = dict(fixed)
        self.forms = []
        effect_pars = []
        n_replaced = 0
        for name, form_name in hyp:
            e = get(name)
            form = e.form(form_name if form_name is not None
                          else _first_form(prob, name), prob)
            self.forms.append((e, form))
            pars = {par.name: par for par in e.parameters(prob)}
            for k, v in form.fixed.items():
                if k in pars:
                    fixed[e.key(k)] = float(v)
            for k in form.replaces:
                if k in prob.prior:
                    fixed[k] = prob.center[k]
                    n_replaced += 1
            effect_pars += [(e.key(k), pars[k]) for k in form.free if e.key(k) not in held]
        self.fixed = fixed
        self.n_replaced = n_replaced
        self.prof = [k for k in prob.tone.mode_names if k not in fixed]
        free = []
        for k, s in prob.prior.items():
            if k in fixed or k in self.prof:
                continue
            c = prob.center[k]
            lo, hi = prob.bounds.get(k, (c - 50 * s, c + 50 * s))
            free.append(Parameter(k, c, lo, hi, s if np.isfinite(s) else 0.1 * (hi - lo)))
        free += [Parameter(key, par.start, par.lo, par.hi, par.scale) for key, par in effect_pars]
        #: the free parameters at their starting values: nuisances at their prior centre,
        #: effects at their start
        self.parameters = Parameters(tuple(free))
        self.eff_params = [k for k, _ in effect_pars]

    def params(self, x) -> dict:
        """The full parameter set at the free parameters ``x``: the fixed ones and ``x`` by name."""
        return {**self.fixed, **dict(zip(self.parameters.names, x))}

    def data(self, p) -> np.ndarray:
        """Standardised data residuals at the parameter set ``p`` (priors left out;
        non-finite as 0)."""
        z = self.prob.residuals(p, with_prior=False)
        return np.where(np.isfinite(z), z, 0.0)

    def prior_z(self, p) -> np.ndarray:
        """Prior residuals ``(value - centre) / sigma`` of the nuisances with a finite
        prior at ``p`` (the profiled calibration modes left out)."""
        prob = self.prob
        return np.array([(p.get(k, prob.center[k]) - prob.center[k]) / prob.prior[k]
                         for k in list(prob.prior) if k not in self.prof
                         and np.isfinite(prob.prior[k])])

    def linearise(self, x, d: dict) -> ModeProfile | None:
        """The calibration modes' linear profile (:class:`ModeProfile`) around the free
        parameters ``x`` with the modes at ``d`` (None when no mode is profiled)."""
        return ModeProfile(self.data, {**self.params(x), **d}, self.prof) if self.prof else None

    def fun(self, lin):
        """The residual function of the free parameters with the modes profiled at ``lin``."""
        def fun(x):
            p = self.params(x)
            if lin is None:
                return np.concatenate([self.data(p), self.prior_z(p)])
            zd, d = lin.solve(self.data(lin.point(p)))
            return np.concatenate([zd, self.prior_z(p), d])
        return fun

    def modes_at(self, lin, x) -> dict:
        """The profiled calibration modes' optimum ``{mode: value}`` at the free
        parameters ``x`` under the linearisation ``lin`` (empty without one)."""
        if lin is None:
            return {}
        return dict(zip(self.prof, lin.solve(self.data(lin.point(self.params(x))))[1]))

    def solve(self, x, lin, nfev: int = MAX_NFEV) -> Optimum:
        """Least squares from ``x`` with the modes profiled at ``lin``.

        A wrong effect against a strong mismatch converges slowly and is rejected
        anyway: the evaluations are capped (the right one converges in a few).  The
        start is moved strictly inside the bounds: a start on a bound can stall the
        trust region.
        """
        fun = self.fun(lin)
        if not len(self.parameters):
            z = fun(np.zeros(0))
            return Optimum(np.zeros(0), 0.5 * float(z @ z), np.zeros((z.size, 0)))
        lo, hi, scale = self.parameters.lower, self.parameters.upper, self.parameters.scales
        memo = {}

        def f(x):
            memo["x"], memo["f"] = np.array(x), fun(x)
            return memo["f"]

        def jac(x):
            # forward differences with absolute steps (a fraction of each parameter's
            # scale): scipy's steps are relative to x, which at a start of 0 (every
            # effect's "absent") probes at ~1e-8 and drowns the slope in rounding
            f0 = memo["f"] if "x" in memo and np.array_equal(memo["x"], x) else fun(x)
            J = np.empty((f0.size, x.size))
            for i in range(x.size):
                h = JACOBIAN_FD_STEP * scale[i] * (
                    1.0 if x[i] + JACOBIAN_FD_STEP * scale[i] <= hi[i] else -1.0)
                xi = np.array(x, dtype=float)
                xi[i] += h
                J[:, i] = (fun(xi) - f0) / h
            return J

        pad = 1e-6 * (hi - lo)
        r = least_squares(f, np.clip(x, lo + pad, hi - pad), jac=jac, bounds=(lo, hi),
                          x_scale=scale, method="trf",
                          max_nfev=nfev, ftol=FIT_TOL, xtol=FIT_TOL)
        return Optimum(r.x, float(r.cost), r.jac)


def initial_point(obj: Objective, init: dict):
    """The first starting point, nuisances from ``init`` (e.g. the baseline's optimum)
    else at their centres, and whether one of them is far from its centre."""
    prob, names = obj.prob, obj.parameters.names
    x0 = list(obj.parameters.values)
    far = False
    for k, v in init.items():
        if k in names:
            i = names.index(k)
            x0[i] = float(np.clip(v, obj.parameters[k].lo, obj.parameters[k].hi))
            far |= k in prob.prior and abs(x0[i] - prob.center[k]) > FAR_NUISANCE * prob.prior[k]
    return np.array(x0), far


def starting_points(obj: Objective, forms: list, x0: np.ndarray, far: bool, starts, lin0) -> list:
    """Starting points of the fit (arrays over ``obj.parameters``).

    ``x0`` (:func:`initial_point`); for an effect with a seed grid (a multimodal chi2
    surface) instead the grid's best point of each sign of its second parameter
    (other parameters at ``x0``, modes profiled at ``lin0``); when ``far``, each
    of those also with the nuisances at their prior centre; and every point of
    ``starts`` (dicts of parameters).
    """
    prob, names = obj.prob, obj.parameters.names
    candidates = [np.array(x0)]
    seeds = next(((e, form.seed_grid) for e, form in forms if form.seed_grid is not None
                  and all(e.key(k) in names for k in form.seed_grid[0])), None)
    if seeds is not None:
        e, ((pa, pb), (ga, gb)) = seeds
        ia, ib = names.index(e.key(pa)), names.index(e.key(pb))
        fun0 = obj.fun(lin0)
        grid = []
        for va in ga:
            for vb in gb:
                x = np.array(x0)
                x[ia], x[ib] = va, vb
                grid.append((float(np.sum(fun0(x) ** 2)), x))
        candidates = [min((g for g in grid if np.sign(g[1][ib]) == sgn),
                          key=lambda g: g[0])[1] for sgn in (-1.0, 1.0)]
    if far:
        # the baseline pushed a nuisance far out (it absorbed part of a strong effect,
        # possibly up to its bound, where the trust region cannot move): also start
        # from the nuisances' prior centre
        is_nuis = np.array([k in prob.prior for k in names])
        x_prior = obj.parameters.values
        candidates += [np.where(is_nuis, x_prior, c) for c in candidates]
    for st in starts or ():
        x = np.array(x0)
        for k, v in st.items():
            if k in names:
                x[names.index(k)] = v
        candidates.append(x)
    return candidates


def solve_profiled(obj: Objective, x, lin, nfev: int = MAX_NFEV):
    """Solution from ``x``, re-linearised at the optimum until the profiled modes settle."""
    r = obj.solve(x, lin, nfev)
    for _ in range(PROFILE_RELIN):
        if lin is None:
            break
        d_new = obj.modes_at(lin, r.x)
        if max(abs(d_new[k] - v) for k, v in zip(obj.prof, lin.d_lin)) < PROFILE_TOL:
            break
        lin = obj.linearise(r.x, d_new)
        r = obj.solve(r.x, lin, nfev)
    return r, lin


def best_solution(obj: Objective, candidates: list, lin0, d_init: dict,
                   nfev: int = MAX_NFEV):
    """The best solution over the starting points: ``(Optimum, its ModeProfile)``.

    Several starts: a short run from each (modes profiled at ``lin0``), and only
    the best one is refined.
    """
    if len(candidates) > 1:
        screened = []
        for x in candidates:
            try:
                screened.append(obj.solve(x, lin0, SCREEN_NFEV))
            except ValueError:
                continue
        if screened:
            candidates = [min(screened, key=lambda r: r.cost).x]
    best, best_lin = None, None
    for x in candidates:
        lin = obj.linearise(x, d_init) if len(obj.parameters) and obj.prof else lin0
        try:
            r, lin = solve_profiled(obj, x, lin, nfev)
        except ValueError:
            continue
        if best is None or r.cost < best.cost:
            best, best_lin = r, lin
    return best, best_lin
