"""The fit of one hypothesis as a result: :class:`FitResult` (parameters with errors,
nuisances, chi2 per observable, the effects' sizes), made from a parameter set and a
covariance (:func:`make_result`), and two one-sided fits combined into a joint one
(:func:`combine_sides`: the tone and gate sides of the model share no parameter)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
from scipy.stats import chi2 as chi2_dist

from dpdfit.analyses.diagnosis.effects import effect_of_key, get
from dpdfit.analyses.diagnosis.model.parameters import Parameters

__all__ = ['FitResult', 'make_result', 'combine_sides', 'param_side']


@dataclass(frozen=True)
class FitResult:
    """Best fit of one hypothesis (the baseline, one effect or several).

    ``params``/``params_err``: the effects' fitted parameters by the fits' names
    (``"<effect>.<param>"``; :meth:`params_of` gives one effect's by its own
    names); ``forms``: the form of each effect; ``sizes``: each effect's size in
    a laboratory's terms (:meth:`dpdfit.analyses.diagnosis.effects.Effect.sizes`);
    ``parameters``: the free parameters (nuisances and effects, the profiled
    calibration modes excluded) at the optimum, each with its bounds, scale, error
    and whether it sits on a bound; ``cov``: their covariance, in their order.
    """

    effect: str
    params: dict
    params_err: dict
    nuisances: dict
    chi2: float
    n_obs: int
    n_par: int
    chi2_by_observable: dict
    n_by_observable: dict
    forms: tuple = ()
    sizes: dict = field(default_factory=dict, repr=False)
    cov: np.ndarray | None = field(default=None, repr=False)
    parameters: Parameters = field(default_factory=Parameters)
    #: the standardised residuals of every data block at the optimum, ``((key, z), ...)``
    #: (keys as :attr:`chi2_by_observable`): what the tempering of the evidence between
    #: two fits reads (:mod:`dpdfit.analyses.diagnosis.evidence.tempering`)
    blocks: tuple = field(default=(), repr=False, compare=False)

    @property
    def free(self) -> tuple:
        """The names of the free parameters, in the order of :attr:`cov`."""
        return self.parameters.names

    @property
    def scales(self) -> tuple:
        """The free parameters' scales, in the order of :attr:`free`."""
        return tuple(p.scale for p in self.parameters)

    @property
    def at_bound(self) -> tuple:
        """The names of the free parameters that sit on a bound."""
        return tuple(p.name for p in self.parameters if p.at_bound)

    @property
    def effects(self) -> tuple:
        """The effects of this hypothesis (empty for the baseline)."""
        return () if self.effect == "baseline" else tuple(self.effect.split("+"))

    @property
    def variant(self) -> str | None:
        """The forms joined by ``+`` (None for the baseline)."""
        return "+".join(self.forms) or None

    @property
    def hypothesis(self) -> tuple:
        """``((effect, form), ...)``: what :func:`fit_hypothesis` takes."""
        return tuple(zip(self.effects, self.forms))

    def params_of(self, name: str) -> dict:
        """One effect's fitted parameters by its own names."""
        pre = name + "."
        return {k[len(pre):]: v for k, v in self.params.items() if k.startswith(pre)}

    def errors_of(self, name: str) -> dict:
        """One effect's parameter errors (1 sigma) by its own names, like :meth:`params_of`."""
        pre = name + "."
        return {k[len(pre):]: v for k, v in self.params_err.items() if k.startswith(pre)}

    @property
    def all_params(self) -> dict:
        """Nuisances and effect parameters: the parameter set of the model at its optimum."""
        return {**self.nuisances, **self.params}

    @property
    def dof(self) -> int:
        """Degrees of freedom, observations minus free parameters (at least 1)."""
        return max(self.n_obs - self.n_par, 1)

    @property
    def bic(self) -> float:
        """Bayesian information criterion ``chi2 + n_par ln(n_obs)`` (the ranking compares it)."""
        return self.chi2 + self.n_par * np.log(self.n_obs)

    @property
    def p_fit(self) -> float:
        """The fit's chi2 p-value (probability of a larger chi2 at :attr:`dof`)."""
        return float(chi2_dist.sf(self.chi2, self.dof))

    def redchi(self) -> dict:
        """Reduced chi2 per observable, ``{observable: chi2 / points}``."""
        return {k: self.chi2_by_observable[k] / max(self.n_by_observable[k], 1)
                for k in self.chi2_by_observable}


def make_result(prob, hyp: list, p: dict, eff_params: list, fixed_eff: dict, cov,
                parameters: Parameters, n_replaced: int = 0) -> FitResult:
    """The :class:`FitResult` of the model at parameters ``p`` (hypothesis ``hyp``, free
    effect parameters ``eff_params``, the forms' fixed ones ``fixed_eff``), with the
    covariance ``cov`` of the free ``parameters`` (their values and errors are taken
    from ``p`` and ``cov``)."""
    cov = None if cov is None else np.asarray(cov, dtype=float)
    err = (np.sqrt(np.clip(np.diag(cov), 0, None)) if cov is not None and cov.size
           else np.zeros(0))
    parameters = Parameters(tuple(
        dataclasses.replace(par, value=float(p[par.name]),
                            error=(float(err[i]) if err.size and not par.at_bound
                                   else float("nan")))
        for i, par in enumerate(parameters)))
    free = parameters.names
    params_ = {k: float(p[k]) for k in eff_params}
    # the forms' fixed parameters too: the model is what the hooks saw
    params_.update(fixed_eff)
    perr = {k: (parameters[k].error if k in free else float("nan")) for k in params_}
    sizes = {name: get(name).sizes(prob, p, cov, list(free), list(parameters.scales))
             for name, _ in hyp}
    # chi2 and counts of the model itself at the optimum (modes at their profiled values)
    n_data = int(np.isfinite(prob.residuals(p, with_prior=False)).sum())
    chi_obs, n_obs, blocks = {}, {}, []
    for lab, z in prob.blocks(p, with_prior=False):
        key = f"{lab['kind']}:{lab['observable']}"
        blocks.append((key, np.array(z, dtype=float)))
        z = z[np.isfinite(z)]
        chi_obs[key] = float(np.sum(z ** 2))
        n_obs[key] = int(z.size)
    z_all = prob.residuals(p)
    z_all = z_all[np.isfinite(z_all)]
    return FitResult(effect="+".join(name for name, _ in hyp) or "baseline",
                     forms=tuple(form for _, form in hyp),
                     params=params_, params_err=perr,
                     nuisances={k: float(v) for k, v in p.items() if k not in params_},
                     chi2=float(np.sum(z_all ** 2)),
                     n_obs=n_data + sum(np.isfinite(v) for v in prob.prior.values()),
                     # every nuisance (fixed ones were fitted in the baseline) + tone offset
                     n_par=len(prob.prior) + 1 + len(eff_params) - n_replaced,
                     chi2_by_observable=chi_obs, n_by_observable=n_obs, sizes=sizes,
                     cov=cov, parameters=parameters, blocks=tuple(blocks))


def combine_sides(prob, a: FitResult, b: FitResult, side: str, hyp=None) -> FitResult:
    """Fit ``a`` with the ``side`` of fit ``b`` (whose effects on ``side`` are the
    joint model's): the two sides of the model share no parameter, so the joint
    optimum is ``a``'s other side and ``b``'s ``side``, the covariance block-diagonal.
    ``hyp``: the joint hypothesis (default: ``a``'s effects, then ``b``'s)."""
    def on_side(k):
        return param_side(prob, k) == side

    ka = [k for k in a.free if not on_side(k)]
    kb = [k for k in b.free if on_side(k)]
    ia, ib = [a.free.index(k) for k in ka], [b.free.index(k) for k in kb]
    cov = np.zeros((len(ka) + len(kb),) * 2)
    if a.cov is not None:
        cov[:len(ka), :len(ka)] = a.cov[np.ix_(ia, ia)]
    if b.cov is not None:
        cov[len(ka):, len(ka):] = b.cov[np.ix_(ib, ib)]
    p = {**{k: v for k, v in a.all_params.items() if not on_side(k)},
         **{k: v for k, v in b.all_params.items() if on_side(k)}}
    eff = ([k for k in a.params if k in a.free and not on_side(k)]
           + [k for k in b.params if k in b.free and on_side(k)])
    fixed_eff = {**{k: v for k, v in a.params.items() if k not in a.free and not on_side(k)},
                 **{k: v for k, v in b.params.items() if k not in b.free and on_side(k)}}
    # a parameter either fit left on a bound stays flagged
    flagged = set(a.at_bound) | set(b.at_bound)
    parameters = Parameters(tuple(
        dataclasses.replace(par, at_bound=par.name in flagged)
        for par in [a.parameters[k] for k in ka] + [b.parameters[k] for k in kb]))
    # nuisances replaced by a form (held at their centre, not counted as parameters)
    n_rep = sum(len(get(n).form(f, prob).replaces) for n, f in
                (hyp if hyp is not None else list(a.hypothesis) + list(b.hypothesis))
                if any(k in prob.prior for k in get(n).form(f, prob).replaces))
    if hyp is None:
        hyp = list(dict.fromkeys(list(a.hypothesis) + list(b.hypothesis)))
    eff = [k for k in dict.fromkeys(eff) if k in ka + kb]
    fixed_eff = {k: v for k, v in fixed_eff.items() if k not in eff}
    return make_result(prob, list(hyp), p, eff, fixed_eff, cov, parameters, n_rep)


def param_side(prob, k: str) -> str:
    """``"tones"`` or ``"gates"``: the side of the model a parameter belongs to."""
    e = effect_of_key(k)
    if e is not None:
        return e.side
    return "tones" if k in prob.tone_nuisances else "gates"
