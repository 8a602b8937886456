"""The gate-rate calibration's relative scatter, learnt by profile likelihood.

A nuisance of the null model, estimated from the gate recordings before any
effect is considered and then held fixed for every hypothesis
(:func:`learn_rate_scatter`).  Prior: when the lab states each setting's rate
error (``xi0_err_khz``), log-normal centred on the stated error,
``RATE_SCATTER_PRIOR_FACTOR`` wide (1 sigma), on a grid spanning +/- 3 sigma;
else log-uniform on [``RATE_SCATTER_MIN``, ``RATE_SCATTER_MAX_FACTOR`` x the
default error].
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.analyses.diagnosis.model.parameters import Parameter, Parameters
from dpdfit.core.parallel import pmap

__all__ = ["learn_rate_scatter", "RATE_SCATTER_MIN", "RATE_SCATTER_MAX_FACTOR",
           "RATE_SCATTER_POINTS", "RATE_SCATTER_PRIOR_FACTOR", "PROFILE_SWEEPS", "gate_forms"]

RATE_SCATTER_MIN = 1e-4
RATE_SCATTER_MAX_FACTOR = 2.0
RATE_SCATTER_POINTS = 7
RATE_SCATTER_PRIOR_FACTOR = 2.0
#: outward continuation sweeps of the rate-scatter profile, at most (another only when the
#: best point moved)
PROFILE_SWEEPS = 3


def gate_forms(prob) -> list:
    """``(effect, catalog form)`` of every default gate-side effect ``prob`` considers:
    free while the rate scatter is estimated (one parameter each: the smooth
    directions a scatter must not absorb; a family's extra freedom would also absorb
    the scatter itself)."""
    return [(EFFECTS[n], prob.forms_of(n)[0]) for n in prob.effects
            if EFFECTS[n].side == "gates" and EFFECTS[n].default and prob.forms_of(n)]


def _gate_nll(prob, rel: float, start: dict | None = None):
    """-2 ln L of the gate recordings of ``prob`` at relative rate scatter ``rel``.

    The gate nuisances *and every gate-side effect's parameters* (a common power
    offset, extra dephasing, heating and preparation error) are fitted with it,
    as in restricted maximum likelihood: the scatter is then what no smooth
    gate-side effect explains, so it cannot absorb one.  ``start``: the fit's
    starting point (a previous result's parameters), else the nuisances' centres
    with every effect absent.
    """
    prob.set_rate_scatter(rel)
    members = [Parameter("prep_split", 0.5, 0.0, 1.0, 0.1),
               Parameter("e01", prob.gate.p_det, 0.0, prob.bounds["e01"][1], 1e-4),
               Parameter("e10", prob.gate.p_det, 0.0, prob.bounds["e10"][1], 1e-4)]
    # every gate-side effect's catalog form (REML-like: the scatter is what no smooth
    # gate-side effect explains), started absent where its bounds allow
    fixed = {}
    for e, form in gate_forms(prob):
        pars = {par.name: par for par in e.parameters(prob)}
        members += [Parameter(e.key(k), 0.0 if pars[k].lo <= 0.0 <= pars[k].hi
                              else pars[k].start, pars[k].lo, pars[k].hi, pars[k].scale)
                    for k in form.free]
        fixed.update({e.key(k): v for k, v in form.fixed.items()})
    for k in range(prob.gate.n_time_scans):
        sd = prob.prior[f"eps_ts{k}"]
        members.append(Parameter(f"eps_ts{k}", 0.0, -50 * sd, 50 * sd, sd))
    free = Parameters(tuple(members))
    if start is not None:
        free = free.at([start[n] for n in free.names])
    names = free.names
    priors = [(n, prob.prior[n]) for n in names if n in prob.prior
              and np.isfinite(prob.prior[n])]
    lo, hi = free.lower, free.upper
    pad = 1e-9 * (hi - lo)

    def fun(x):
        p = {**fixed, **dict(zip(names, x))}
        z = [np.ravel(zz) for _, zz in prob.blocks(p, with_prior=False, with_tones=False)]
        z = np.concatenate(z + [[(p[n] - prob.center[n]) / s for n, s in priors]])
        return np.where(np.isfinite(z), z, 0.0)

    # -2 ln L to ~1e-3 is all the posterior over the grid needs
    r = least_squares(fun, np.clip(free.values, lo + pad, hi - pad),
                      bounds=(lo, hi), x_scale=free.scales, max_nfev=200, ftol=1e-6, xtol=1e-6)
    p = {**fixed, **dict(zip(names, r.x))}
    _, ld = prob.gate_whitened(p, logdet=True)
    ld += sum(2 * np.log(s) for n, s in priors if n.startswith("eps_ts"))
    return float(2 * r.cost + ld), p


_SHARED: dict = {}


def _cold_fit(rel: float):
    return _gate_nll(_SHARED["prob"], rel)


def _profile(prob, grid: np.ndarray) -> np.ndarray:
    """-2 ln L profiled over the gate nuisances and effects at each scatter of ``grid``.

    A profile is a minimum: each point is fitted from the nuisances' centres
    (cold) and then again from its neighbour's optimum, sweeping outwards from
    the best point (continuation), keeping the lower.  The cold fits alone stop
    in local minima of the 10-odd-parameter fit at some grid points (seen as
    jumps of 5-10 units between neighbours on another simulator's campaigns),
    and the posterior then piles up on whichever point happened to converge.
    """
    _SHARED["prob"] = prob
    try:
        # the cold fits are independent: over the cores (the problem is inherited)
        fits = pmap(_cold_fit, [((float(v),), {}) for v in grid])
    finally:
        _SHARED.clear()
    i0 = None
    for _ in range(PROFILE_SWEEPS):
        i1 = int(np.argmin([f[0] for f in fits]))
        if i1 == i0:
            break               # the same sweep again would repeat the same starts
        i0 = i1
        # the two directions are independent: over the cores
        _SHARED["prob"] = prob
        try:
            ups, downs = pmap(_sweep, [((grid, fits, i0, +1), {}), ((grid, fits, i0, -1), {})])
        finally:
            _SHARED.clear()
        for i, f in {**ups, **downs}.items():
            if f[0] < fits[i][0] - 1e-6:
                fits[i] = f
    return np.array([f[0] for f in fits])


def _sweep(grid, fits, i0: int, direction: int) -> dict:
    """Continuation from grid point ``i0`` outwards in ``direction``: each point fitted
    from its neighbour's (better) optimum: ``{index: (nll, parameters)}``."""
    prob = _SHARED["prob"]
    out = {}
    prev = fits[i0]
    for i in range(i0 + direction, grid.size if direction > 0 else -1, direction):
        f = _gate_nll(prob, grid[i], start=prev[1])
        if fits[i][0] < f[0]:
            f = fits[i]
        out[i] = f
        prev = f
    return out


def learn_rate_scatter(prob) -> dict:
    """Relative scatter of the gate-rate calibration of ``prob``'s campaign (a nuisance).

    Prior: log-normal centred on the lab's stated rate error, a factor
    ``RATE_SCATTER_PRIOR_FACTOR`` wide, when the lab states it per setting;
    else log-uniform on [``RATE_SCATTER_MIN``, ``RATE_SCATTER_MAX_FACTOR`` x
    the default error].  On a log grid, each point with the gate nuisances and
    the gate-side effects refitted; the scatter is the root of the posterior
    mean variance.  Left set on ``prob`` (held fixed for every hypothesis).
    """
    stated = prob.gate.stated_rate_error
    if prob.gate.rate_error_stated:
        # the lab's stated error is information: it is known to a factor of
        # about two, not to two decades (a log-uniform prior down to 1e-4 lets a
        # handful of settings pull the scatter far below it, and the gate-side
        # effects then fit the calibration's own scatter)
        k = RATE_SCATTER_PRIOR_FACTOR ** 3
        grid = np.geomspace(stated / k, stated * k, RATE_SCATTER_POINTS + 2)
        log_prior = -0.5 * (np.log(grid / stated) / np.log(RATE_SCATTER_PRIOR_FACTOR)) ** 2
    else:
        hi = max(RATE_SCATTER_MAX_FACTOR * stated, 2 * RATE_SCATTER_MIN)
        grid = np.geomspace(RATE_SCATTER_MIN, hi, RATE_SCATTER_POINTS)
        log_prior = np.zeros(grid.size)
    nll = _profile(prob, grid)
    # marginalised, not maximised: with ten-odd settings the profile is often flat
    # or two-humped (a common offset against a scatter), and its maximum then jumps
    # between the grid's ends.  The rate error enters the likelihood as a Gaussian
    # variance, so the posterior (prior weights on the log grid) is summarised by
    # its mean *variance* (moment-matched predictive).
    lpost = log_prior - 0.5 * nll
    w = np.exp(lpost - lpost.max())
    best = float(np.sqrt(np.sum(w * grid ** 2) / np.sum(w)))
    prob.set_rate_scatter(best)
    return {"rel": float(best), "db": prob.gate.rate_error_db(),
            "stated_rel": prob.gate.stated_rate_error,
            "profile": {f"{v:.3g}": float(n - nll.min()) for v, n in zip(grid, nll)}}
