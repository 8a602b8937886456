"""Posterior of the amplitude transfer function of one calibration run (emcee).

The recorded powers are modelled exactly as in :mod:`dpdfit.fits.calibration`::

    P_i = (sum_k b_k A_i^k)^2 + e_i,   e_i ~ N(0, power_err_i^2),

with flat priors on ``b`` restricted to ``b_1 > 0`` (which removes the sign
symmetry of the square).  Without ``power_err`` one common noise sigma is a
parameter (``log sigma``, flat prior, i.e. a 1/sigma prior on sigma).  The
log-probability is evaluated for all walkers at once (emcee ``vectorize=True``:
one ``(n, K) @ (K, walkers)`` product per step).

Sampler.  :class:`emcee.EnsembleSampler` with, by default (``moves="laplace"``),
a mixture of 90 % *independence Metropolis-Hastings* proposals and 10 % of
emcee's stretch move.  The independence proposal is a multivariate Student-t
(6 degrees of freedom, heavier tails than the target) centred on the
least-squares optimum of :func:`dpdfit.fits.calibration.fit_amplitude` with its
Gauss-Newton covariance (the Laplace approximation); the MH correction makes
the chain target the exact posterior whatever the proposal, and because the
posterior of this problem is nearly Gaussian nearly every proposal is
accepted and successive states are almost independent (integrated
autocorrelation time ~1-2 steps instead of ~50-100 for the stretch move in
8 dimensions).  ``moves="stretch"`` gives plain emcee.  Walkers start from
draws of the same Laplace approximation.

Convergence is checked, never assumed.  After discarding the first
``burn`` fraction of steps, the integrated autocorrelation time ``tau`` of every
parameter and of ``A_corr`` is estimated with
:func:`emcee.autocorr.integrated_time` (``c=5``, ``tol=0`` so that the estimate
is always returned; the length requirement is checked here).  A result is
*refused* (:class:`ConvergenceError`) when

* the kept chain is shorter than ``50 * max(tau)`` steps,
* ``tau`` is not finite, or
* the mean acceptance fraction is below 0.05,

unless ``force=True`` (then ``converged`` is False and the report says so).
``n_independent = n_walkers * n_kept_steps / max(tau)``.

Progress: a tqdm bar (:func:`dpdfit.core.progress.progress_bar`, ``progress=True``)
per step.  The result keeps the whole chain (``chain``, ``log_prob``, ``acceptance_fraction``).

The run-to-run drift of the calibration is :mod:`dpdfit.fits.drift`; the
propagation of posterior and drift into the fidelity estimate is
:mod:`dpdfit.analyses.propagation`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from dpdfit.core.defaults import AMPLITUDE_ORDER
from dpdfit.core.display import Displayable
from dpdfit.core.progress import progress_bar
from dpdfit.errors import DpdfitError, FitError, InputError
from dpdfit.fits.calibration import AmplitudeCalibration, fit_amplitude
from dpdfit.fits.draws import quantile_summary, read_only, shift_y1

__all__ = ["ConvergenceError", "PosteriorResult", "sample_amplitude_posterior",
           "laplace_independence_move", "MIN_TAU_MULTIPLE", "MIN_ACCEPTANCE"]

#: A chain must be at least this many autocorrelation times long.
MIN_TAU_MULTIPLE = 50
#: Lowest acceptable mean acceptance fraction of the walkers.
MIN_ACCEPTANCE = 0.05
#: Degrees of freedom of the Student-t independence proposal.
_T_DF = 6.0


class ConvergenceError(DpdfitError):
    """The MCMC chain is too short (or mixes too badly) to report."""


def laplace_independence_move(mean, cov, df=_T_DF):
    """An emcee ``MHMove``: independence proposal from a multivariate Student-t.

    The proposal ``t_df(mean, cov)`` ignores the current state; the
    Metropolis-Hastings ratio carries ``log q(x0) - log q(x)`` so that the chain
    targets the exact posterior whatever the proposal.
    """
    import emcee       # here: importing emcee takes ~0.6 s, and only sampling needs it
    mean = np.asarray(mean, dtype=float)
    L = np.linalg.cholesky(cov)
    Linv = np.linalg.inv(L)
    d = mean.size

    def logq(x):
        z = (x - mean) @ Linv.T
        m = np.sum(z * z, axis=-1)
        return -0.5 * (df + d) * np.log1p(m / df)

    def proposal(x0, random):
        nw = x0.shape[0]
        z = random.randn(nw, d)
        w = np.sqrt(df / random.chisquare(df, size=nw))
        x = mean + (z * w[:, None]) @ L.T
        return x, logq(x0) - logq(x)

    return emcee.moves.MHMove(proposal, ndim=d)


@dataclass(frozen=True, repr=False)
class PosteriorResult(Displayable):
    """Posterior draws of the amplitude transfer function of one calibration run.

    Attributes
    ----------
    powers : tuple of int
        ``(1, ..., K)``.
    b_draws : ndarray (n_draws, K)
        Raw power-domain coefficients ``b_k`` (kept chain, flattened).
    a_draws : ndarray (n_draws, K)
        Normalised ``a_k = b_k / b_1``.
    A_corr_draws : ndarray (n_draws,)
        ``y(1) = sum a_k``.
    sigma_draws : ndarray or None
        Noise sigma draws when ``power_err`` was not given.
    tau : ndarray
        Integrated autocorrelation time (steps) per parameter, ``A_corr`` last.
    acceptance : float
        Mean acceptance fraction over walkers.
    n_independent : float
        ``n_walkers * n_kept_steps / max(tau)``.
    n_walkers, n_steps, n_discard : int
    converged : bool
        Passed the convergence policy (False only with ``force=True``).
    fit : AmplitudeCalibration
        The least-squares fit the chain was started from.
    moves : str
    wall_time : float
        Seconds spent sampling.
    chain, log_prob, acceptance_fraction : ndarray or None
        The whole emcee chain ``(n_steps, n_walkers, n_params)`` (burn-in included; ``b_k``
        then ``log sigma`` if sampled; ~1 MB by default), its log-posterior and per walker.
    """

    powers: tuple
    b_draws: np.ndarray
    a_draws: np.ndarray
    A_corr_draws: np.ndarray
    sigma_draws: np.ndarray | None
    tau: np.ndarray
    acceptance: float
    n_independent: float
    n_walkers: int
    n_steps: int
    n_discard: int
    converged: bool
    fit: AmplitudeCalibration
    moves: str = "laplace"
    wall_time: float = float("nan")
    source: dict = field(default_factory=dict)
    chain: np.ndarray | None = field(default=None, repr=False)
    log_prob: np.ndarray | None = field(default=None, repr=False)
    acceptance_fraction: np.ndarray | None = field(default=None, repr=False)

    @property
    def tau_max(self) -> float:
        """The longest integrated autocorrelation time (steps) over the parameters."""
        return float(np.max(self.tau))

    def A_corr_summary(self) -> dict:
        """Median, 68 % and 95 % quantiles of the ``A_corr = y(1)`` draws (``q16``, ...)."""
        return {k: float(v) for k, v in quantile_summary(self.A_corr_draws).items()}

    def coefficient_summary(self) -> dict:
        """Median, 68 % and 95 % quantiles of the ``a_k`` draws, as lists over k."""
        q = quantile_summary(self.a_draws)
        return {k: np.asarray(v).tolist() for k, v in q.items()}

    def interval(self, level: float = 0.68) -> tuple[float, float]:
        """Equal-tailed credible interval of ``A_corr``."""
        lo, hi = np.quantile(self.A_corr_draws, [(1 - level) / 2, (1 + level) / 2])
        return float(lo), float(hi)

    def to_dict(self) -> dict:
        return {
            "powers": list(self.powers),
            "A_corr": self.A_corr_summary(),
            "coefficients": self.coefficient_summary(),
            "tau": self.tau.tolist(), "tau_max": self.tau_max,
            "acceptance": self.acceptance, "n_independent": self.n_independent,
            "n_walkers": self.n_walkers, "n_steps": self.n_steps, "n_discard": self.n_discard,
            "n_draws": int(self.A_corr_draws.size), "converged": bool(self.converged),
            "moves": self.moves, "wall_time_s": self.wall_time,
            "fit_A_corr": self.fit.A_corr, "fit_A_corr_stderr": self.fit.A_corr_stderr,
            "sigma": None if self.sigma_draws is None else float(np.median(self.sigma_draws)),
            "source": dict(self.source),
        }

    def report(self) -> str:
        s = self.A_corr_summary()
        lines = [f"[[Amplitude posterior]]  K = {max(self.powers)}, emcee ({self.moves}), "
                 f"{self.n_walkers} walkers x {self.n_steps} steps ({self.n_discard} discarded)",
                 f"    convergence : tau_max {self.tau_max:.2f} steps, chain "
                 f"{(self.n_steps - self.n_discard) / self.tau_max:.0f} tau long (>= "
                 f"{MIN_TAU_MULTIPLE} required), acceptance {self.acceptance:.3f}, "
                 f"{self.n_independent:.0f} independent samples"
                 + ("" if self.converged else "   ** NOT CONVERGED (forced) **"),
                 f"    A_corr=y(1) : median {s['median']:.6f}  68% [{s['q16']:.6f}, {s['q84']:.6f}]"
                 f"  95% [{s['q2.5']:.6f}, {s['q97.5']:.6f}]",
                 f"    LSQ fit     : {self.fit.A_corr:.6f} +/- {self.fit.A_corr_stderr:.6f}",
                 "    coefficient   median            q16             q84"]
        q = quantile_summary(self.a_draws)
        for i, p in enumerate(self.powers):
            lines.append(f"      a_{p:<3d} {q['median'][i]:+15.8e} {q['q16'][i]:+15.8e} "
                         f"{q['q84'][i]:+15.8e}")
        return "\n".join(lines)


def _check_arrays(A, power, power_err):
    A = np.asarray(A, dtype=float)
    power = np.asarray(power, dtype=float)
    sig = None if power_err is None else np.asarray(power_err, dtype=float)
    if A.ndim != 1 or power.shape != A.shape or (sig is not None and sig.shape != A.shape):
        raise InputError("A, power and power_err must be 1-D arrays of equal length")
    return A, power, sig


def _check_settings(order, sampled_sigma, n_walkers, n_steps, moves):
    n_par = order + sampled_sigma
    if n_walkers < 2 * n_par or n_walkers % 2:
        raise InputError(f"n_walkers must be even and >= 2 x the number of parameters "
                         f"({2 * n_par}), got {n_walkers}")
    if n_steps < 10:
        raise InputError(f"n_steps must be >= 10, got {n_steps}")
    if moves not in ("laplace", "stretch"):
        raise InputError(f"moves must be 'laplace' or 'stretch', got {moves!r}")


def _laplace_approximation(fit: AmplitudeCalibration, sampled_sigma: bool):
    """Mean and covariance of the parameters (``b``, then ``log sigma`` if sampled)."""
    order = fit.order
    mean = np.asarray(fit.raw_coefficients).copy()
    cov = np.array(fit.raw_covariance)
    if sampled_sigma:
        s_hat = math.sqrt(fit.chi2 / max(fit.dof, 1))
        mean = np.append(mean, math.log(s_hat))
        c2 = np.zeros((order + 1, order + 1))
        c2[:order, :order] = cov
        c2[order, order] = 1.0 / (2 * max(fit.dof, 1))
        cov = c2
    # tiny jitter keeps the Cholesky well defined for nearly singular covariances
    cov = cov + np.diag(np.diag(cov)) * 1e-12
    return mean, cov


def _log_probability(A, power, sig, order):
    """Vectorised log-posterior ``theta (walkers, ndim) -> (walkers,)``."""
    V = A[:, None] ** np.arange(1, order + 1)          # (n, K)
    n = A.size
    w = None if sig is None else 1.0 / sig

    def log_prob(theta):
        theta = np.atleast_2d(theta)
        b = theta[:, :order]
        model = (V @ b.T) ** 2                          # (n, walkers)
        if w is None:
            ls = theta[:, order]
            r = (power[:, None] - model) * np.exp(-ls)[None, :]
            lp = -0.5 * np.sum(r * r, axis=0) - n * ls
        else:
            r = (power[:, None] - model) * w[:, None]
            lp = -0.5 * np.sum(r * r, axis=0)
        lp = np.where(b[:, 0] > 0, lp, -np.inf)
        return np.where(np.isfinite(lp), lp, -np.inf)

    return log_prob


def _run_chain(log_prob, mean, cov, n_walkers, n_steps, moves, rng, progress):
    """Run emcee from Laplace draws; returns ``(sampler, wall_time)``."""
    import emcee       # here: importing emcee takes ~0.6 s, and only sampling needs it
    ndim = mean.size
    try:
        L = np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        raise FitError("the least-squares covariance is not positive definite (a degenerate "
                       "fit): no Laplace start for the sampler") from None
    p0 = mean + rng.standard_normal((n_walkers, ndim)) @ L.T
    p0[:, 0] = np.abs(p0[:, 0])
    if moves == "laplace":
        mv = [(laplace_independence_move(mean, cov), 0.9), (emcee.moves.StretchMove(), 0.1)]
    else:
        mv = None
    sampler = emcee.EnsembleSampler(n_walkers, ndim, log_prob, vectorize=True, moves=mv)
    sampler.random_state = np.random.RandomState(
        int(rng.integers(0, 2 ** 31 - 1))).get_state()
    t0 = time.perf_counter()
    with progress_bar(total=n_steps, desc="emcee", progress=progress) as bar:
        for _ in sampler.sample(p0, iterations=n_steps):
            bar.update()
    return sampler, time.perf_counter() - t0


def _convergence(chain, order, acceptance, burn, force):
    """Autocorrelation times (parameters, then ``A_corr``) and the convergence verdict.

    Returns ``(tau, tau_max, problems)``; raises :class:`ConvergenceError` on
    problems unless ``force``.
    """
    from emcee.autocorr import integrated_time   # as emcee above: only when sampling
    b_chain = chain[..., :order]
    Ac_chain = b_chain.sum(axis=-1) / b_chain[..., 0]
    full = np.concatenate([chain, Ac_chain[..., None]], axis=-1)
    tau = np.asarray(integrated_time(full, c=5, tol=0, quiet=True), dtype=float)
    n_kept = chain.shape[0]
    tau_max = float(np.max(tau)) if np.all(np.isfinite(tau)) else float("inf")
    problems = []
    if not np.isfinite(tau_max):
        problems.append("autocorrelation time is not finite")
    elif n_kept < MIN_TAU_MULTIPLE * tau_max:
        problems.append(f"chain of {n_kept} kept steps is only {n_kept / tau_max:.1f} "
                        f"autocorrelation times long (tau = {tau_max:.1f} steps; "
                        f">= {MIN_TAU_MULTIPLE} required): run more steps "
                        f"(>= {int(math.ceil(MIN_TAU_MULTIPLE * tau_max / (1 - burn)))})")
    if acceptance < MIN_ACCEPTANCE:
        problems.append(f"acceptance fraction {acceptance:.3f} < {MIN_ACCEPTANCE}")
    if problems and not force:
        raise ConvergenceError("posterior chain not converged: " + "; ".join(problems)
                               + " (or force=True / --force to report it anyway)")
    return tau, tau_max, problems


def sample_amplitude_posterior(A, power, power_err=None, order: int = AMPLITUDE_ORDER, *,
                               drift_sigma=None, n_walkers: int = 32, n_steps: int = 400,
                               burn: float = 0.2, seed=None, progress: bool = False,
                               force: bool = False, moves: str = "laplace",
                               fit: AmplitudeCalibration | None = None,
                               source: dict | None = None) -> PosteriorResult:
    """Sample the posterior of the amplitude polynomial with emcee.

    Parameters
    ----------
    A, power, power_err : array_like
        One calibration run (as for :func:`dpdfit.fits.calibration.fit_amplitude`).
        Without ``power_err`` a common noise sigma is sampled too.
    order : int
        Polynomial order K.
    drift_sigma : float, optional
        Accepted for symmetry with :func:`dpdfit.analyses.propagation.propagate`;
        the chain itself is the posterior of *this run*.  A value here only adds
        the drift perturbation of ``y(1)`` (see :mod:`dpdfit.fits.drift`) to
        ``A_corr_draws`` and ``a_draws`` of the returned result (predictive
        draws of a later day).
    n_walkers, n_steps : int
        Ensemble size and chain length (steps per walker).
    burn : float
        Fraction of steps discarded before estimating tau and keeping draws.
    seed : int, optional
    progress : bool or None
        A bar over the steps on stderr (None: when stderr is a terminal).
    force : bool
        Return an unconverged chain (flagged) instead of raising.
    moves : {"laplace", "stretch"}
        Laplace-t independence proposals mixed with stretch (default) or
        plain emcee stretch moves.
    fit : AmplitudeCalibration, optional
        Precomputed least-squares fit of the same data (saves the fit).

    Raises
    ------
    ConvergenceError
        Chain shorter than 50 autocorrelation times, non-finite tau or
        acceptance below 0.05 (unless ``force``).
    """
    A, power, sig = _check_arrays(A, power, power_err)
    if fit is None:
        fit = fit_amplitude(A, power, sig, order)
    order = fit.order
    _check_settings(order, sig is None, n_walkers, n_steps, moves)
    mean, cov = _laplace_approximation(fit, sig is None)
    rng = np.random.default_rng(seed)
    sampler, wall = _run_chain(_log_probability(A, power, sig, order), mean, cov, n_walkers,
                               n_steps, moves, rng, progress)
    discard = int(burn * n_steps)
    chain = sampler.get_chain(discard=discard)          # (steps, walkers, ndim)
    acc = float(np.mean(sampler.acceptance_fraction))
    tau, tau_max, problems = _convergence(chain, order, acc, burn, force)
    flat = chain.reshape(-1, mean.size)
    b = flat[:, :order]
    a = b / b[:, :1]
    Ac = a.sum(axis=1)
    if drift_sigma is not None and float(drift_sigma) > 0:
        a, Ac = shift_y1(a, rng.normal(0.0, float(drift_sigma), size=Ac.size))
    n_ind = float(n_walkers * chain.shape[0] / tau_max) if np.isfinite(tau_max) else 0.0
    return PosteriorResult(
        powers=tuple(fit.powers), b_draws=read_only(b), a_draws=read_only(a),
        A_corr_draws=read_only(Ac),
        sigma_draws=None if sig is not None else read_only(np.exp(flat[:, order])),
        tau=read_only(tau), acceptance=acc, n_independent=n_ind, n_walkers=int(n_walkers),
        n_steps=int(n_steps), n_discard=discard, converged=not problems, fit=fit,
        moves=moves, wall_time=wall, source=dict(source or fit.source or {}),
        chain=read_only(sampler.get_chain()), log_prob=read_only(sampler.get_log_prob()),
        acceptance_fraction=read_only(np.asarray(sampler.acceptance_fraction, dtype=float)))
