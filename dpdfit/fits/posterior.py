"""Posterior of the amplitude transfer function (emcee) and propagation of calibration drift.

Posterior of one calibration run
--------------------------------
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

Progress: emcee's own bar needs ``tqdm`` (not a dependency), so the chain is
run by iterating ``sampler.sample(..., iterations=n_steps)`` and the project's
:class:`dpdfit.core.progress.Progress` is updated per step (``progress=True``).

Run-to-run drift (Supplement S2)
--------------------------------
:func:`drift_model` fits every run of a multi-run amplitude file
(:func:`~dpdfit.fits.calibration.fit_amplitude`) and takes ``y(1) = A_corr`` per run
with its standard error ``s_i``.  The *excess* scatter over the fit errors is::

    sigma_drift^2 = max(var(y1_i) - mean(s_i^2), 0)       (stationary spread),
    q = max(sum_j [(y1_{j+1} - y1_j)^2 - s_j^2 - s_{j+1}^2] / sum_j dt_j, 0)

(``q``: random-walk rate, per day, from consecutive runs in time order).  The
drift expected after ``d`` days is a random walk that saturates at the
difference of two independent draws of the stationary spread::

    sigma_drift(d)^2 = min(q d, 2 sigma_drift^2),     sigma_drift(0) = 0.

Without timestamps only the stationary part is known and
``sigma_drift(d > 0) = sqrt(2) sigma_drift`` (conservative).

Predictive true transfer function of a later day: a posterior draw ``a`` of
the calibration run, with ``y(1)`` moved by ``delta ~ N(0, sigma_drift(d)^2)``
by scaling the nonlinear part of the polynomial::

    a_1 = 1,  a_k -> a_k * (y1 - 1 + delta) / (y1 - 1)   (k >= 2),

so the unit slope at the origin is kept and the *shape* of the compression is
kept (S2: the family of curves differs mainly in the onset of compression).

Propagation into the fidelity estimate
--------------------------------------
For the chosen amplitude ``A`` and DPD flag the RF waveform (Cardioid(1,2),
after DPD with the exact inverse of the *calibration's* point-estimate fit,
as the sweep does) is the same for every draw; only the true transfer
function differs.  The optical field ``y(|x|) exp(i[arg x + phi(|x|)])`` is
*linear in the coefficients* ``a_k``, so its Fourier amplitude at every tone
bin is ``c = a @ M`` with ``M_k = DFT_bin[|x|^k sign(x) exp(i phi(|x|))]``
(computed once per flag); likewise ``mean |y|^2 = a^T G a``.  This is the
exact forward model of :mod:`dpdfit.analyses.sweep` evaluated for all draws at once
(tested against :func:`dpdfit.analyses.sweep.run_sweep` to 1e-9 dB), followed by the
batched :func:`dpdfit.models.fidelity.estimate` on the tone powers.  Reported per flag:
``F_est`` (mean of the sidebands, as the sweep's ``mean`` row), ``R10`` (dB,
mean of sidebands) and ``eta_bar``: median, 16/84 % and 2.5/97.5 % quantiles.

Recalibration question
----------------------
:func:`recalibration` finds the smallest ``|delta y(1)|`` (either sign) of the
true transfer function, relative to the calibration used for the LUT, that
lowers ``F_est(A, DPD)`` by ``loss`` (default 1e-4), and with the drift model
the staleness ``d`` at which ``sigma_drift(d) = |delta|`` (``d = delta^2/q``;
``None`` when the saturated drift ``sqrt(2) sigma_drift`` never reaches it).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from dpdfit.fits.calibration import AmplitudeCalibration, PhaseCalibration, fit_amplitude
from dpdfit.errors import DpdfitError, FitError, InputError

__all__ = ["ConvergenceError", "PosteriorResult", "sample_amplitude_posterior", "DriftModel",
           "drift_model", "PropagationResult", "propagate", "recalibration", "plot_corner",
           "add_propagate_command", "MIN_TAU_MULTIPLE"]

#: A chain must be at least this many autocorrelation times long.
MIN_TAU_MULTIPLE = 50
MIN_ACCEPTANCE = 0.05
_T_DF = 6.0


class ConvergenceError(DpdfitError):
    """The MCMC chain is too short (or mixes too badly) to report."""


def _frozen(a) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


def _q(x, axis=0) -> dict:
    x = np.asarray(x, dtype=float)
    q = np.quantile(x, [0.5, 0.16, 0.84, 0.025, 0.975], axis=axis)
    return {"median": q[0], "q16": q[1], "q84": q[2], "q2.5": q[3], "q97.5": q[4]}


# =========================================================================== posterior


class _LaplaceIndependenceMove:
    """Factory for an emcee MHMove: independence proposal from a multivariate t."""

    @staticmethod
    def make(mean, cov, df=_T_DF):
        import emcee
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


@dataclass(frozen=True)
class PosteriorResult:
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

    @property
    def tau_max(self) -> float:
        return float(np.max(self.tau))

    def A_corr_summary(self) -> dict:
        return {k: float(v) for k, v in _q(self.A_corr_draws).items()}

    def coefficient_summary(self) -> dict:
        q = _q(self.a_draws)
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
        q = _q(self.a_draws)
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


def sample_amplitude_posterior(A, power, power_err=None, order: int = 8, *,
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
        Accepted for symmetry with :func:`propagate`; the chain itself is the
        posterior of *this run*.  A value here only adds the drift
        perturbation of ``y(1)`` (see module doc) to ``A_corr_draws`` and
        ``a_draws`` of the returned result (predictive draws of a later day).
    n_walkers, n_steps : int
        Ensemble size and chain length (steps per walker).
    burn : float
        Fraction of steps discarded before estimating tau and keeping draws.
    seed : int, optional
    progress : bool
        Show a progress line on stderr.
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
    import emcee
    from emcee.autocorr import integrated_time
    from dpdfit.core.progress import Progress

    A, power, sig = _check_arrays(A, power, power_err)
    if fit is None:
        fit = fit_amplitude(A, power, sig, order)
    order = fit.order
    if n_walkers < 2 * (order + (sig is None)) or n_walkers % 2:
        raise InputError(f"n_walkers must be even and >= 2 x the number of parameters "
                         f"({2 * (order + (sig is None))}), got {n_walkers}")
    if n_steps < 10:
        raise InputError(f"n_steps must be >= 10, got {n_steps}")
    if moves not in ("laplace", "stretch"):
        raise InputError(f"moves must be 'laplace' or 'stretch', got {moves!r}")
    V = A[:, None] ** np.arange(1, order + 1)          # (n, K)
    b0 = np.asarray(fit.raw_coefficients)
    cov = np.array(fit.raw_covariance)
    mean = b0.copy()
    n = A.size
    if sig is None:
        s_hat = math.sqrt(fit.chi2 / max(fit.dof, 1))
        mean = np.append(mean, math.log(s_hat))
        c2 = np.zeros((order + 1, order + 1))
        c2[:order, :order] = cov
        c2[order, order] = 1.0 / (2 * max(fit.dof, 1))
        cov = c2
        w = None
    else:
        w = 1.0 / sig
    # tiny jitter keeps the Cholesky well defined for nearly singular covariances
    cov = cov + np.diag(np.diag(cov)) * 1e-12
    ndim = mean.size

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

    rng = np.random.default_rng(seed)
    L = np.linalg.cholesky(cov)
    p0 = mean + rng.standard_normal((n_walkers, ndim)) @ L.T
    p0[:, 0] = np.abs(p0[:, 0])
    if moves == "laplace":
        mv = [(_LaplaceIndependenceMove.make(mean, cov), 0.9), (emcee.moves.StretchMove(), 0.1)]
    else:
        mv = None
    sampler = emcee.EnsembleSampler(n_walkers, ndim, log_prob, vectorize=True, moves=mv)
    sampler.random_state = np.random.RandomState(
        int(rng.integers(0, 2 ** 31 - 1))).get_state()
    t0 = time.perf_counter()
    with Progress("emcee", n_steps, enabled=progress) as bar:
        for _ in sampler.sample(p0, iterations=n_steps):
            bar.update()
    wall = time.perf_counter() - t0
    discard = int(burn * n_steps)
    chain = sampler.get_chain(discard=discard)          # (steps, walkers, ndim)
    b_chain = chain[..., :order]
    Ac_chain = b_chain.sum(axis=-1) / b_chain[..., 0]
    full = np.concatenate([chain, Ac_chain[..., None]], axis=-1)
    tau = np.asarray(integrated_time(full, c=5, tol=0, quiet=True), dtype=float)
    acc = float(np.mean(sampler.acceptance_fraction))
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
    if acc < MIN_ACCEPTANCE:
        problems.append(f"acceptance fraction {acc:.3f} < {MIN_ACCEPTANCE}")
    if problems and not force:
        raise ConvergenceError("posterior chain not converged: " + "; ".join(problems)
                               + " (or force=True / --force to report it anyway)")
    flat = chain.reshape(-1, ndim)
    b = flat[:, :order]
    a = b / b[:, :1]
    Ac = a.sum(axis=1)
    if drift_sigma is not None and float(drift_sigma) > 0:
        a, Ac = _perturb(a, rng.normal(0.0, float(drift_sigma), size=Ac.size))
    n_ind = float(n_walkers * n_kept / tau_max) if np.isfinite(tau_max) else 0.0
    return PosteriorResult(
        powers=tuple(fit.powers), b_draws=_frozen(b), a_draws=_frozen(a),
        A_corr_draws=_frozen(Ac),
        sigma_draws=None if sig is not None else _frozen(np.exp(flat[:, order])),
        tau=_frozen(tau), acceptance=acc, n_independent=n_ind, n_walkers=int(n_walkers),
        n_steps=int(n_steps), n_discard=discard, converged=not problems, fit=fit,
        moves=moves, wall_time=wall, source=dict(source or fit.source or {}))


def _perturb(a, delta):
    """Move y(1) of each row of ``a`` by ``delta``, scaling the nonlinear part (a_1 = 1 kept)."""
    a = np.array(a, dtype=float, copy=True)
    y1 = a.sum(axis=1)
    nl = y1 - 1.0
    safe = np.where(np.abs(nl) > 1e-12, nl, 1e-12)
    a[:, 1:] *= ((nl + delta) / safe)[:, None]
    return a, a.sum(axis=1)


# =========================================================================== drift


@dataclass(frozen=True)
class DriftModel:
    """Run-to-run drift of ``y(1)`` from repeated calibration runs (Supplement S2).

    Attributes
    ----------
    runs : list of str
        Run labels in time order.
    days : ndarray or None
        Run times in days since the first run (None without timestamps).
    y1, y1_stderr : ndarray
        ``A_corr`` of each run and its fit standard error.
    sigma_drift : float
        Excess stationary run-to-run scatter of ``y(1)``.
    rate_per_day : float or None
        Random-walk variance rate ``q`` (per day) from consecutive runs.
    """

    runs: list
    days: np.ndarray | None
    y1: np.ndarray
    y1_stderr: np.ndarray
    sigma_drift: float
    rate_per_day: float | None
    raw_sd: float

    def sigma(self, stale_days: float) -> float:
        """Expected drift (1 sigma) of y(1) after ``stale_days`` days."""
        d = float(stale_days)
        if d < 0:
            raise InputError(f"stale_days must be >= 0, got {d}")
        if d == 0:
            return 0.0
        cap = 2 * self.sigma_drift ** 2
        if self.rate_per_day is None:
            return math.sqrt(cap)
        return math.sqrt(min(self.rate_per_day * d, cap))

    def days_until(self, delta: float) -> float | None:
        """Staleness (days) at which sigma(d) reaches ``|delta|``; None if never."""
        d2 = float(delta) ** 2
        if d2 > 2 * self.sigma_drift ** 2:
            return None
        if self.rate_per_day is None or self.rate_per_day <= 0:
            return None if self.rate_per_day is not None else 0.0
        return d2 / self.rate_per_day

    def to_dict(self) -> dict:
        return {"n_runs": len(self.runs), "sigma_drift": self.sigma_drift,
                "rate_per_day": self.rate_per_day, "raw_sd": self.raw_sd,
                "mean_y1": float(np.mean(self.y1)),
                "mean_stderr": float(np.sqrt(np.mean(self.y1_stderr ** 2))),
                "span_days": None if self.days is None else float(self.days[-1] - self.days[0])}


def _runs_frame(runs_df: pd.DataFrame, source: str | None = None) -> pd.DataFrame:
    name = source or runs_df.attrs.get("source")
    for col in ("A", "power"):
        if col not in runs_df.columns:
            raise InputError("required column is missing", file=name, column=col)
    df = runs_df.copy()
    if "run" not in df.columns:
        df["run"] = "1"
    df["run"] = df["run"].astype(str)
    if "timestamp" in df.columns and not pd.api.types.is_datetime64_any_dtype(df["timestamp"]):
        ts = pd.to_datetime(df["timestamp"], errors="coerce", utc=True, format="mixed")
        bad = ts.isna().to_numpy()
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"'{df['timestamp'].iloc[i]}' is not a date/time (use ISO 8601)",
                             file=name, column="timestamp", row=i + 1)
        df["timestamp"] = ts
    return df


def _fit_run(sub: pd.DataFrame, order: int, run: str, name) -> AmplitudeCalibration:
    err = sub["power_err"].to_numpy(float) if "power_err" in sub.columns else None
    try:
        return fit_amplitude(sub["A"].to_numpy(float), sub["power"].to_numpy(float), err, order,
                             source={"file": name, "run": run})
    except DpdfitError as exc:
        raise FitError(f"{name or 'runs'}: run '{run}': {exc}") from None


def _ordered_runs(df: pd.DataFrame):
    runs = list(dict.fromkeys(df["run"].tolist()))
    if "timestamp" in df.columns:
        t0 = df.groupby("run", sort=False)["timestamp"].min()
        runs = sorted(runs, key=lambda r: t0[r])
        days = np.array([(t0[r] - t0[runs[0]]).total_seconds() / 86400.0 for r in runs])
    else:
        days = None
    return runs, days


def drift_model(runs_df: pd.DataFrame, order: int = 8, *, fits: dict | None = None) -> DriftModel:
    """Estimate the run-to-run drift of ``y(1)`` from a multi-run amplitude table.

    ``runs_df`` has columns ``run, A, power`` (+ ``power_err``, ``timestamp``);
    every run is fitted with :func:`~dpdfit.fits.calibration.fit_amplitude`.  See the
    module docstring for the estimator.  Needs at least 2 runs.
    """
    name = runs_df.attrs.get("source")
    df = _runs_frame(runs_df)
    runs, days = _ordered_runs(df)
    if len(runs) < 2:
        raise InputError(f"drift model needs at least 2 calibration runs, got {len(runs)}",
                         file=name, column="run")
    fits = dict(fits or {})
    y1, se = [], []
    for r in runs:
        f = fits.get(r) or _fit_run(df[df["run"] == r], order, r, name)
        fits[r] = f
        y1.append(f.A_corr)
        se.append(f.A_corr_stderr)
    y1, se = np.array(y1), np.array(se)
    raw_var = float(np.var(y1, ddof=1))
    sigma = math.sqrt(max(raw_var - float(np.mean(se ** 2)), 0.0))
    rate = None
    if days is not None:
        dt = np.diff(days)
        if np.sum(dt) > 0:
            num = np.sum(np.diff(y1) ** 2 - se[1:] ** 2 - se[:-1] ** 2)
            rate = max(float(num / np.sum(dt)), 0.0)
    return DriftModel(runs=runs, days=None if days is None else _frozen(days), y1=_frozen(y1),
                      y1_stderr=_frozen(se), sigma_drift=sigma, rate_per_day=rate,
                      raw_sd=math.sqrt(raw_var))


# =========================================================================== propagation


class _Forward:
    """Exact, draw-batched forward model at one amplitude for both DPD flags."""

    def __init__(self, lut_fit: AmplitudeCalibration, phase: PhaseCalibration | None, A: float,
                 nu=1.84e6, xi0=20e3, nbar=0.1, formula="exact", eta_ref=0.80):
        from dpdfit.models.transfer import TransferFunction
        from dpdfit.models.waveforms import cardioid, sample_grid, synthesize, predistort
        self.tones = cardioid()
        self.grid = sample_grid(nu, xi0, self.tones)
        self.tf = TransferFunction(lut_fit.powers, tuple(lut_fit.coefficients),
                                   () if phase is None else phase.powers,
                                   () if phase is None else tuple(phase.coefficients))
        self.powers = np.asarray(lut_fit.powers)
        self.nbar, self.formula, self.eta_ref = nbar, formula, eta_ref
        self.harmonics = (0, 1, 2, 3)
        w = synthesize(self.tones, self.grid, np.array([float(A)]))[0]
        self.M, self.G, self.M2 = {}, {}, {}
        self.pm_powers = None if phase is None else np.asarray(phase.powers)
        kb, kr = self.grid.tone_bins(self.harmonics)
        N = self.grid.n_samples
        for dpd in (0, 1):
            rf = predistort(w, self.tf) if dpd else w
            mag = np.minimum(np.abs(rf), 1.0)
            ph = np.angle(rf) + self.tf.f_pm(mag)
            basis = mag[None, :] ** self.powers[:, None]            # (K, N)
            spec = np.fft.fft(basis * np.exp(1j * ph)[None, :], axis=-1) / N
            self.M[dpd] = (spec[:, kb], spec[:, kr])                 # (K, 4) each
            self.G[dpd] = basis @ basis.T / N                        # mean y^2 = a G a
            if self.pm_powers is not None:
                # first-order response to a phase-coefficient perturbation db:
                # exp(i(phi + dphi)) = exp(i phi)(1 + i dphi), dphi = sum_l db_l |x|^l
                pb = mag[None, :] ** self.pm_powers[:, None]          # (P, N)
                s2 = np.fft.fft(basis[:, None, :] * pb[None, :, :] * np.exp(1j * ph), axis=-1) / N
                self.M2[dpd] = (1j * s2[..., kb], 1j * s2[..., kr])  # (K, P, 4) each
        self.gate_signs = tuple(np.sign([self.tones.r_blue[self.tones.n.index(k)]
                                         for k in (1, 2)]))

    def evaluate(self, a, dpd: int, db=None) -> dict:
        """Tone powers etc. for coefficient draws ``a`` (D, K); ``db`` (D, P) optional
        phase-coefficient perturbations, to first order (|dphi| ~ 1e-3 rad: the
        neglected second order is ~1e-6 of the tone amplitudes)."""
        from dpdfit.models.fidelity import estimate
        a = np.atleast_2d(a)
        Mb, Mr = self.M[dpd]
        cb, cr = a @ Mb, a @ Mr
        if db is not None and dpd in self.M2:
            M2b, M2r = self.M2[dpd]
            cb = cb + np.einsum("dk,dl,klh->dh", a, db, M2b)
            cr = cr + np.einsum("dk,dl,klh->dh", a, db, M2r)
        Pb = 10 * np.log10(np.maximum(np.abs(cb) ** 2, 1e-300))
        Pr = 10 * np.log10(np.maximum(np.abs(cr) ** 2, 1e-300))
        F = 0.5 * sum(estimate(P, self.harmonics, gate_signs=self.gate_signs, nbar=self.nbar,
                               formula=self.formula).F_est for P in (Pr, Pb))
        R10 = 0.5 * ((Pr[:, 1] - Pr[:, 0]) + (Pb[:, 1] - Pb[:, 0]))
        y1 = a.sum(axis=1)
        eta = self.eta_ref * np.einsum("di,ij,dj->d", a, self.G[dpd], a) / y1 ** 2
        return {"F_est": F, "R10_dB": R10, "eta_bar": eta}


@dataclass(frozen=True)
class PropagationResult:
    """Distribution of F_est, R10 and eta_bar per DPD flag at one amplitude."""

    A: float
    stale_days: float
    n_draws: int
    sigma_drift: float
    samples: dict            # {"dpd": {"F_est": arr, ...}, "no_dpd": {...}}
    point: dict              # point estimates (calibration fit as truth), same keys
    tau: float | None
    n_independent: float | None
    wall_time: float = float("nan")
    recalibration: dict | None = None

    def summary(self) -> dict:
        out = {}
        for flag, d in self.samples.items():
            row = {}
            for key, arr in d.items():
                q = _q(arr)
                for qn, v in q.items():
                    row[f"{key}_{qn}"] = float(v)
                row[f"{key}_point"] = float(self.point[flag][key])
            out[flag] = row
        return out

    def to_dict(self) -> dict:
        d = self.summary()
        d.update({"tau": self.tau, "n_independent": self.n_independent, "A": self.A,
                  "stale_days": self.stale_days, "draws": self.n_draws,
                  "sigma_drift_y1": self.sigma_drift, "wall_time_s": self.wall_time})
        if self.recalibration is not None:
            d["recalibration"] = self.recalibration
        return d

    def report(self) -> str:
        s = self.summary()
        lines = [f"[[Drift propagation]]  A = {self.A:g}, calibration {self.stale_days:g} days "
                 f"old (sigma of y(1) drift {self.sigma_drift:.5f}), {self.n_draws} draws"]
        if self.tau is not None:
            lines.append(f"    posterior   : tau {self.tau:.2f} steps, "
                         f"{self.n_independent:.0f} independent samples")
        for flag in ("dpd", "no_dpd"):
            r = s[flag]
            lines.append(f"    {flag:7s} F_est median {r['F_est_median']:.6f}  68% "
                         f"[{r['F_est_q16']:.6f}, {r['F_est_q84']:.6f}]  95% "
                         f"[{r['F_est_q2.5']:.6f}, {r['F_est_q97.5']:.6f}]  (point "
                         f"{r['F_est_point']:.6f})")
            lines.append(f"            R10 median {r['R10_dB_median']:.2f} dB  68% "
                         f"[{r['R10_dB_q16']:.2f}, {r['R10_dB_q84']:.2f}]   eta_bar "
                         f"{r['eta_bar_median']:.4f} [{r['eta_bar_q16']:.4f}, "
                         f"{r['eta_bar_q84']:.4f}]")
        if self.recalibration:
            rc = self.recalibration
            days = rc["days_until"]
            lines.append(f"    recalibrate : a drift of y(1) by {rc['delta_y1']:+.5f} costs "
                         f"{rc['loss']:g} in F_est at A = {rc['A']:g} with DPD; expected after "
                         + ("never (saturated drift smaller)" if days is None
                            else f"{days:.2f} days"))
        return "\n".join(lines)


def _prepare(posterior_or_runs, order, run, seed, n_walkers, n_steps, force, progress):
    """-> (posterior, lut_fit, drift or None)."""
    if isinstance(posterior_or_runs, PosteriorResult):
        return posterior_or_runs, posterior_or_runs.fit, None
    if not isinstance(posterior_or_runs, pd.DataFrame):
        raise InputError("propagate needs a PosteriorResult or a runs DataFrame")
    name = posterior_or_runs.attrs.get("source")
    df = _runs_frame(posterior_or_runs)
    runs, _ = _ordered_runs(df)
    chosen = runs[-1] if run in (None, "latest") else str(run)
    if chosen not in runs:
        raise InputError(f"run '{chosen}' not found; runs present: {', '.join(runs[:20])}",
                         file=name, column="run")
    fits = {r: _fit_run(df[df["run"] == r], order, r, name) for r in runs}
    sub = df[df["run"] == chosen]
    err = sub["power_err"].to_numpy(float) if "power_err" in sub.columns else None
    post = sample_amplitude_posterior(sub["A"].to_numpy(float), sub["power"].to_numpy(float),
                                      err, order, n_walkers=n_walkers, n_steps=n_steps,
                                      seed=seed, force=force, progress=progress,
                                      fit=fits[chosen])
    drift = None
    if len(runs) >= 2:
        d2 = df.copy()
        d2.attrs["source"] = name
        drift = drift_model(d2, order, fits=fits)
    return post, fits[chosen], drift


def _predictive_draws(post, drift, stale_days, phase, draws, rng):
    """Draws of the later day's true transfer function: ``(a, db, sigma_drift)``.

    ``a`` (draws, K): posterior draws of the normalised amplitude coefficients,
    their ``y(1)`` moved by the drift ``N(0, sigma(stale_days))``; ``db``
    (draws, P) or None: phase-coefficient perturbations from the phase fit's
    posterior, which is exactly Gaussian ``N(b, C)`` (linear model, flat prior).
    """
    if stale_days > 0 and drift is None:
        raise InputError("stale_days > 0 needs a drift model (at least 2 calibration runs)")
    sd = drift.sigma(stale_days) if drift is not None else 0.0
    idx = rng.integers(0, post.a_draws.shape[0], size=int(draws))
    b = np.asarray(post.b_draws)[idx]
    a = b / b[:, :1]
    if sd > 0:
        a, _ = _perturb(a, rng.normal(0.0, sd, size=a.shape[0]))
    db = None if phase is None else rng.multivariate_normal(
        np.zeros(len(phase.powers)), np.asarray(phase.covariance), size=a.shape[0])
    return a, db, sd


def propagate(posterior_or_runs, A: float, stale_days: float = 0.0, draws: int = 10000, *,
              phase: PhaseCalibration | None = None, lut_fit: AmplitudeCalibration | None = None,
              drift: DriftModel | None = None, order: int = 8, run=None, seed=None,
              n_walkers: int = 32, n_steps: int = 400, force: bool = False,
              progress: bool = False, nu: float = 1.84e6, xi0: float = 20e3,
              nbar: float = 0.1, formula: str = "exact", eta_ref: float = 0.80,
              recalibration_loss: float | None = None, chunk: int = 5000) -> PropagationResult:
    """Distribution of ``F_est``, ``R10`` and ``eta_bar`` at amplitude ``A``, both DPD flags.

    Parameters
    ----------
    posterior_or_runs : PosteriorResult or pandas.DataFrame
        A posterior of the calibration run used for the LUT, or a multi-run
        amplitude table (columns ``run, A, power[, power_err, timestamp]``):
        then the latest run (or ``run``) is the calibration, its fit the LUT,
        its posterior the uncertainty, and all runs give the drift model.
    A : float
        Peak RF-envelope amplitude (target amplitude of the waveform), 0..1.
    stale_days : float
        Age of the calibration; the true transfer function's ``y(1)`` is
        perturbed by ``N(0, sigma_drift(stale_days))``.
    draws : int
        Number of predictive draws (resampled from the chain).
    phase : PhaseCalibration, optional
        Fixed phase polynomial (both for the LUT's forward model and the
        truth); None = AM only.
    lut_fit : AmplitudeCalibration, optional
        The calibration the predistortion table is built from (default: the
        posterior's least-squares fit).
    drift : DriftModel, optional
        Required when ``stale_days > 0`` and a posterior is given.
    recalibration_loss : float, optional
        Also answer :func:`recalibration` for this fidelity loss.
    """
    t0 = time.perf_counter()
    A = float(A)
    if not 0 < A <= 1:
        raise InputError(f"A must lie in (0, 1], got {A}")
    if draws < 1:
        raise InputError(f"draws must be >= 1, got {draws}")
    post, fit0, drift0 = _prepare(posterior_or_runs, order, run, seed, n_walkers, n_steps,
                                  force, progress)
    drift = drift or drift0
    lut_fit = lut_fit or fit0
    a, db, sd = _predictive_draws(post, drift, stale_days, phase, draws,
                                  np.random.default_rng(None if seed is None else seed + 1))
    fw = _Forward(lut_fit, phase, A, nu, xi0, nbar, formula, eta_ref)
    samples, point = {}, {}
    for dpd, key in ((1, "dpd"), (0, "no_dpd")):
        parts = [fw.evaluate(a[i:i + chunk], dpd, None if db is None else db[i:i + chunk])
                 for i in range(0, a.shape[0], chunk)]
        samples[key] = {k: _frozen(np.concatenate([p[k] for p in parts])) for k in parts[0]}
        pt = fw.evaluate(np.asarray(lut_fit.coefficients)[None, :], dpd)
        point[key] = {k: float(v[0]) for k, v in pt.items()}
    rc = None
    if recalibration_loss is not None:
        rc = recalibration(lut_fit, A, recalibration_loss, drift=drift, phase=phase,
                           _forward=fw)
    return PropagationResult(A=A, stale_days=float(stale_days), n_draws=int(draws),
                             sigma_drift=sd, samples=samples, point=point,
                             tau=post.tau_max, n_independent=post.n_independent,
                             wall_time=time.perf_counter() - t0, recalibration=rc)


def _first_crossing_rows(x, y, level):
    """Row-wise first rise of ``y`` through ``level`` along increasing ``x``, log-log interpolated.

    Vectorised form of :func:`dpdfit.analyses.sweep._first_crossing` for a batch of
    curves (rows); NaN where the curve never reaches ``level`` or starts above it.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    order = np.argsort(x, axis=1)
    x = np.take_along_axis(x, order, axis=1)
    y = np.take_along_axis(y, order, axis=1)
    above = y >= level
    has = above.any(axis=1) & ~above[:, 0]
    i = np.where(has, np.argmax(above, axis=1), 1)
    r = np.arange(x.shape[0])
    with np.errstate(divide="ignore", invalid="ignore"):
        lx0, lx1 = np.log(x[r, i - 1]), np.log(x[r, i])
        ly0, ly1 = np.log(np.maximum(y[r, i - 1], 1e-300)), np.log(np.maximum(y[r, i], 1e-300))
        out = np.exp(lx0 + (np.log(level) - ly0) * (lx1 - lx0) / (ly1 - ly0))
    return np.where(has, out, np.nan)


def threshold_distribution(posterior_or_runs, stale_days: float = 0.0, draws: int = 2000, *,
                           amplitudes=None, levels=(1e-2, 1e-3, 1e-4), phase=None, run=None,
                           seed=None, order: int = 8, n_walkers: int = 32, n_steps: int = 400,
                           force: bool = False, nu: float = 1.84e6, xi0: float = 20e3,
                           nbar: float = 0.1, formula: str = "exact", eta_ref: float = 0.80) -> dict:
    """Distribution of the threshold efficiencies ``eta_th(eps)`` and ``eta_bar_corr``.

    Every predictive draw of the true transfer function (as in :func:`propagate`,
    including the Gaussian posterior of the phase polynomial when ``phase`` is given)
    is pushed through the sweep on an amplitude grid (default 40 points on
    0.05..1) for both flags, with the predistortion table of the calibration;
    per draw, ``eta_th`` is the first rise of ``eps_est`` through each level in
    log-log interpolation (as :func:`dpdfit.analyses.sweep.thresholds`).  Returns, per
    flag and level, the median and the 68 % / 95 % intervals over the draws
    (``null`` entries when fewer than half of the draws reach the level), and
    the fraction of draws that reach it.
    """
    amplitudes = np.linspace(0.05, 1.0, 40) if amplitudes is None else np.asarray(amplitudes)
    post, fit0, drift = _prepare(posterior_or_runs, order, run, seed, n_walkers, n_steps,
                                 force, False)
    a, db, _ = _predictive_draws(post, drift, stale_days, phase, draws,
                                 np.random.default_rng(None if seed is None else seed + 2))
    out = {}
    for dpd, key in ((1, "dpd"), (0, "no_dpd")):
        eps = np.empty((a.shape[0], amplitudes.size))
        eta = np.empty_like(eps)
        for j, A in enumerate(amplitudes):
            r = _Forward(fit0, phase, float(A), nu, xi0, nbar, formula, eta_ref).evaluate(a, dpd, db)
            eps[:, j] = 1.0 - r["F_est"]
            eta[:, j] = r["eta_bar"]
        row = {}
        for lev in levels:
            th = _first_crossing_rows(eta, eps, lev)
            ok = np.isfinite(th)
            name = f"{lev:.0e}".replace("e-0", "e-")
            if ok.mean() >= 0.5:
                q = np.quantile(th[ok], [0.5, 0.16, 0.84, 0.025, 0.975])
                row[name] = {"median": float(q[0]), "q16": float(q[1]), "q84": float(q[2]),
                             "q2.5": float(q[3]), "q97.5": float(q[4]),
                             "fraction_reached": float(ok.mean())}
            else:
                row[name] = {"median": None, "fraction_reached": float(ok.mean())}
        out[key] = row
    out.update({"stale_days": float(stale_days), "draws": int(draws),
                "amplitudes": [float(v) for v in amplitudes]})
    return out


def recalibration(calibration: AmplitudeCalibration, A: float, loss: float = 1e-4, *,
                  drift: DriftModel | None = None, phase: PhaseCalibration | None = None,
                  nu: float = 1.84e6, xi0: float = 20e3, nbar: float = 0.1,
                  formula: str = "exact", _forward=None) -> dict:
    """Drift of ``y(1)`` that costs ``loss`` in ``F_est(A, DPD)``, and when to expect it.

    The LUT comes from ``calibration``; the true transfer function is the same
    polynomial with ``y(1)`` moved by ``delta`` (nonlinear part scaled, see
    module doc).  Returns ``{"delta_y1", "delta_plus", "delta_minus", "loss",
    "A", "F_est_calibrated", "days_until", "sigma_drift", "rate_per_day"}``:
    ``delta_y1`` is the smaller in magnitude of the two signed solutions
    (``None`` where a sign never reaches the loss within |delta| <= 0.2), and
    ``days_until`` the staleness at which the drift model's ``sigma_drift(d)``
    reaches ``|delta_y1|`` (``None``: never).
    """
    from scipy.optimize import brentq
    if not loss > 0:
        raise InputError(f"fidelity loss must be > 0, got {loss}")
    fw = _forward or _Forward(calibration, phase, A, nu, xi0, nbar, formula)
    a0 = np.asarray(calibration.coefficients)[None, :]
    F0 = float(fw.evaluate(a0, 1)["F_est"][0])

    def lossf(delta):
        a, _ = _perturb(a0, np.array([delta]))
        return F0 - float(fw.evaluate(a, 1)["F_est"][0]) - loss

    sols = {}
    for sgn, key in ((1, "delta_plus"), (-1, "delta_minus")):
        grid = sgn * np.geomspace(1e-6, 0.2, 60)
        vals = np.array([lossf(d) for d in grid])
        hit = np.flatnonzero(vals >= 0)
        if hit.size == 0:
            sols[key] = None
            continue
        i = hit[0]
        lo = 0.0 if i == 0 else grid[i - 1]
        sols[key] = float(brentq(lossf, lo, grid[i], xtol=1e-12))
    cands = [v for v in sols.values() if v is not None]
    delta = min(cands, key=abs) if cands else None
    days = None
    if delta is not None and drift is not None:
        days = drift.days_until(delta)
    return {"delta_y1": delta, **sols, "loss": float(loss), "A": float(A),
            "F_est_calibrated": F0, "days_until": days,
            "sigma_drift": None if drift is None else drift.sigma_drift,
            "rate_per_day": None if drift is None else drift.rate_per_day}


# =========================================================================== corner plot


def plot_corner(result: PosteriorResult, path, params=None, bins: int = 40,
                max_points: int = 4000) -> str:
    """Corner plot (matplotlib only) of ``A_corr`` and selected ``a_k``.

    ``params`` lists names among ``"A_corr"`` and ``"a2".."aK"`` (default:
    ``A_corr, a2, a3, a4``).  Diagonal: histograms with the median and 68 %
    interval; off-diagonal: scatter of up to ``max_points`` draws.
    """
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    cols = {"A_corr": np.asarray(result.A_corr_draws)}
    for i, p in enumerate(result.powers):
        if p > 1:
            cols[f"a{p}"] = np.asarray(result.a_draws)[:, i]
    params = list(params or ["A_corr"] + [f"a{p}" for p in result.powers[1:4]])
    for p in params:
        if p not in cols:
            raise InputError(f"unknown corner-plot parameter {p!r}; choose from {list(cols)}")
    X = np.column_stack([cols[p] for p in params])
    rng = np.random.default_rng(0)
    sel = rng.choice(X.shape[0], size=min(max_points, X.shape[0]), replace=False)
    k = len(params)
    fig, axes = plt.subplots(k, k, figsize=(2.2 * k, 2.2 * k), squeeze=False)
    for i in range(k):
        for j in range(k):
            ax = axes[i, j]
            if j > i:
                ax.set_visible(False)
                continue
            if i == j:
                ax.hist(X[:, i], bins=bins, histtype="step", color="k")
                for q, ls in ((0.5, "-"), (0.16, "--"), (0.84, "--")):
                    ax.axvline(np.quantile(X[:, i], q), color="C0", ls=ls, lw=0.8)
                ax.set_yticks([])
            else:
                ax.plot(X[sel, j], X[sel, i], ",", color="k", alpha=0.5)
            if i == k - 1:
                ax.set_xlabel(params[j])
            else:
                ax.set_xticklabels([])
            if j == 0 and i > 0:
                ax.set_ylabel(params[i])
            elif j > 0:
                ax.set_yticklabels([])
    fig.suptitle(f"posterior, tau {result.tau_max:.1f}, {result.n_independent:.0f} indep.")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return str(path)


# =========================================================================== CLI


def _read_runs(path: str) -> pd.DataFrame:
    from dpdfit.recordings.tables import read_table
    df = read_table(path, ["A", "power"], ["power_err", "run", "timestamp"],
                    ranges={"A": (0.0, 1.0)}, positive=["power_err"])
    return df


def cmd_propagate(args) -> int:
    """``dpdfit propagate``: drift propagation into F_est (report or JSON)."""
    from dpdfit.recordings.outputs import to_jsonable
    df = _read_runs(args.calibration_runs)
    phase = None
    if args.phase:
        from dpdfit.fits.calibration import calibrate_phase
        from dpdfit.recordings.tables import read_calibration
        phase = calibrate_phase(read_calibration(args.phase, "phase", run="latest"))
    res = propagate(df, args.A, stale_days=args.stale_days, draws=args.draws, phase=phase,
                    order=args.order, run=args.run, seed=args.seed, n_walkers=args.walkers,
                    n_steps=args.steps, force=args.force, progress=args.progress,
                    recalibration_loss=args.loss)
    d = res.to_dict()
    if args.thresholds:
        d["thresholds"] = threshold_distribution(
            df, stale_days=args.stale_days, draws=min(args.draws, 2000), phase=phase,
            order=args.order, run=args.run, seed=args.seed, n_walkers=args.walkers,
            n_steps=args.steps, force=args.force)
    if args.json:
        print(json.dumps(to_jsonable(d), indent=2))
    else:
        print(res.report())
        if args.thresholds:
            for flag in ("no_dpd", "dpd"):
                print(f"    eta_th {flag:7s}: " + ", ".join(
                    f"{lev}: " + ("-" if v.get("median") is None else
                                  f"{v['median']:.4f} [{v['q16']:.4f}, {v['q84']:.4f}]")
                    for lev, v in d["thresholds"][flag].items()))
    return 0


def add_propagate_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit propagate`` on an argparse sub-parsers object.

    ``dpdfit propagate --calibration-runs runs.csv --A 0.5 [--stale-days D]
    [--draws N] [--json] [--force]``; the registered ``func`` returns an exit
    code and raises :class:`~dpdfit.errors.DpdfitError` on bad input.
    """
    s = subparsers.add_parser(
        "propagate", help="posterior + drift of the AOM calibration propagated into F_est",
        description="Posterior (emcee) of the latest calibration run, run-to-run drift from "
                    "all runs, propagated through the Cardioid forward model at one amplitude "
                    "for both DPD flags: quantiles of F_est, R10 and eta_bar.")
    s.add_argument("--calibration-runs", required=True, metavar="RUNS.csv",
                   help="amplitude calibration runs: run, timestamp, A, power[, power_err]")
    s.add_argument("--A", type=float, required=True, help="RF-envelope peak amplitude (0..1]")
    s.add_argument("--stale-days", type=float, default=0.0,
                   help="age of the calibration, days (0)")
    s.add_argument("--draws", type=int, default=10000, help="predictive draws (10000)")
    s.add_argument("--run", help="run used as the calibration (default: latest)")
    s.add_argument("--phase", metavar="PHASE.csv", help="phase calibration (latest run; "
                   "default: AM-only forward model)")
    s.add_argument("--order", type=int, default=8, help="amplitude polynomial order (8)")
    s.add_argument("--walkers", type=int, default=32, help="emcee walkers (32)")
    s.add_argument("--steps", type=int, default=400, help="emcee steps per walker (400)")
    s.add_argument("--seed", type=int, default=0, help="random seed (0)")
    s.add_argument("--loss", type=float, default=1e-4,
                   help="fidelity loss for the recalibration answer (1e-4)")
    s.add_argument("--thresholds", action="store_true",
                   help="also the distribution of the threshold efficiencies (40-point sweep "
                        "per draw; uses min(draws, 2000) draws)")
    s.add_argument("--force", action="store_true", help="report an unconverged chain")
    s.add_argument("--progress", action="store_true", help="progress line on stderr")
    s.add_argument("--json", action="store_true", help="print JSON instead of a report")
    s.set_defaults(func=cmd_propagate)
    return s
