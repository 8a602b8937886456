"""The calibration photodiode's noise, learnt from the calibration runs.

A lab's ``calibration_amplitude.csv`` need not carry ``power_err``.  A single
noise level estimated from one run's residuals is then the only option for one
run -- but a photodiode's noise is rarely the same at every power (a constant
electronic floor plus a part proportional to the signal: laser intensity noise,
shot noise).  With several runs of the same AOM the noise model can be learnt:
each run is fitted (K = 8, unweighted: unbiased whatever the noise), and
``sigma(P)^2 = a^2 + (b P)^2`` is fitted by maximum likelihood to all runs'
residuals at once.  An unweighted fit absorbs part of the noise, unevenly when
the noise is not the same everywhere, so each residual's expected variance is
the exact ``diag((I - H) Sigma (I - H))`` of the fit's hat matrix ``H``: it is
linear in ``a^2`` and ``b^2`` (a global ``n/(n - K)`` correction instead put
``a`` 15 % high).  The model run is then fitted with those errors, so
its covariance -- and the calibration modes the diagnosis profiles -- follow
the photodiode's real noise.
"""

from __future__ import annotations

import dataclasses
from dataclasses import asdict, dataclass

import numpy as np
from scipy.optimize import minimize

from dpdfit.core.defaults import AMPLITUDE_ORDER, PHASE_MIN_A, PHASE_ORDER
from dpdfit.core.display import Displayable
from dpdfit.fits.calibration import fit_amplitude, fit_phase
from dpdfit.errors import DpdfitError

__all__ = ["PowerNoise", "PhaseNoise", "fit_power_noise", "fit_phase_noise",
           "model_run_with_noise", "phase_run_with_noise", "with_power_noise",
           "with_phase_noise", "MIN_RUNS"]

#: runs needed to learn the noise model (with fewer, one level per run as before)
MIN_RUNS = 3


@dataclass(frozen=True, repr=False)
class PowerNoise(Displayable):
    """``sigma(P) = sqrt(a^2 + (b P)^2)`` (power units), learnt from ``n_runs`` runs."""

    a: float
    b: float
    n_runs: int
    n_points: int

    def sigma(self, P) -> np.ndarray:
        """1-sigma noise of a recorded power ``P``, ``sqrt(a^2 + (b P)^2)`` (power units)."""
        P = np.asarray(P, dtype=float)
        return np.sqrt(self.a ** 2 + (self.b * P) ** 2)

    def to_dict(self) -> dict:
        return asdict(self)


def fit_power_noise(A, power, runs, order: int = AMPLITUDE_ORDER,
                    fits: dict | None = None) -> PowerNoise | None:
    """Noise model of the recorded powers from every run's residuals (module doc).

    Returns None with fewer than :data:`MIN_RUNS` runs that can be fitted.  ``fits``: a
    dict that receives each run's fit without errors, ``{run label: fit}`` (for a
    caller that needs them again).
    """
    A, power, runs = np.asarray(A, float), np.asarray(power, float), np.asarray(runs)
    res, u, w = [], [], []
    n_runs = 0
    for r in dict.fromkeys(runs.tolist()):
        sel = runs == r
        if sel.sum() <= order + 2:
            continue
        try:
            f = fit_amplitude(A[sel], power[sel], None, order)
        except DpdfitError:
            continue
        if fits is not None:
            fits[r] = f
        p = f.power(A[sel])
        res.append(power[sel] - p)
        uu, ww = _residual_weights(A[sel], p, order)
        u.append(uu)
        w.append(ww)
        n_runs += 1
    if n_runs < MIN_RUNS:
        return None
    r2 = np.concatenate(res) ** 2
    a, b = _two_term_variance(r2, np.concatenate(u), np.concatenate(w))
    return PowerNoise(a, b, n_runs, int(r2.size))


def _residual_weights(A, x, order):
    """Expected squared residual of an unweighted fit in powers ``1..order`` of ``A`` is
    ``alpha^2 u + beta^2 w`` when the noise variance is ``alpha^2 + (beta x)^2``:
    ``u = diag(M)``, ``w = (M * M) @ x^2`` with ``M = I - H`` (symmetric, idempotent)."""
    X = np.asarray(A, float)[:, None] ** np.arange(1, order + 1)
    Q, _ = np.linalg.qr(X)
    M = np.eye(A.size) - Q @ Q.T
    return np.diag(M).copy(), (M * M) @ (np.asarray(x, float) ** 2)


def _two_term_variance(r2, u, w):
    """ML fit of ``E[r^2] = a^2 u + b^2 w`` to squared residuals ``r2`` (Gaussian)."""
    s0 = np.sqrt(np.mean(r2))
    xmax = np.sqrt(max(w.max(), 1e-300))

    def nll(t):
        v = np.exp(2 * t[0]) * u + np.exp(2 * t[1]) * w
        return 0.5 * np.sum(np.log(v) + r2 / v)

    best = min((minimize(nll, [np.log(s0 * f0), np.log(s0 * f1 / xmax)],
                         method="Nelder-Mead", options={"xatol": 1e-6, "fatol": 1e-8})
                for f0, f1 in ((1.0, 0.1), (0.1, 1.0), (0.5, 0.5))), key=lambda o: o.fun)
    return float(np.exp(best.x[0])), float(np.exp(best.x[1]))


@dataclass(frozen=True, repr=False)
class PhaseNoise(Displayable):
    """``sigma(A) = sqrt(c^2 + (d/A)^2)`` (rad): a floor plus heterodyne noise ~ 1/amplitude."""

    c: float
    d: float
    n_runs: int
    n_points: int

    def sigma(self, A) -> np.ndarray:
        """1-sigma noise (rad) of a recorded phase at amplitude ``A``, ``sqrt(c^2 + (d/A)^2)``."""
        A = np.asarray(A, dtype=float)
        return np.sqrt(self.c ** 2 + (self.d / np.maximum(A, 1e-6)) ** 2)

    def to_dict(self) -> dict:
        return asdict(self)


def fit_phase_noise(A, phase, runs, order: int = PHASE_ORDER,
                    A_min: float = PHASE_MIN_A) -> PhaseNoise | None:
    """Noise model of the recorded phases from every run's residuals on ``A >= A_min``."""
    A, phase, runs = np.asarray(A, float), np.asarray(phase, float), np.asarray(runs)
    res, u, w = [], [], []
    n_runs = 0
    for r in dict.fromkeys(runs.tolist()):
        sel = (runs == r) & (A >= A_min)
        if sel.sum() <= order + 2:
            continue
        try:
            f = fit_phase(A[sel], phase[sel], None, order, A_min=A_min)
        except DpdfitError:
            continue
        res.append(phase[sel] - f.phi(A[sel]))
        uu, ww = _residual_weights(A[sel], 1.0 / A[sel], order)
        u.append(uu)
        w.append(ww)
        n_runs += 1
    if n_runs < MIN_RUNS:
        return None
    r2 = np.concatenate(res) ** 2
    c, d = _two_term_variance(r2, np.concatenate(u), np.concatenate(w))
    return PhaseNoise(c, d, n_runs, int(r2.size))


def model_run_with_noise(cf, fits: dict | None = None):
    """The model (table) run of a campaign folder with its power errors.

    ``(CalibrationData, PowerNoise or None)``: when the file has no ``power_err``
    and holds at least :data:`MIN_RUNS` runs, the errors are the learnt noise model
    at each point's fitted power (:func:`fit_power_noise`); otherwise the data as
    recorded.  ``dpdfit analyze`` and ``dpdfit diagnose`` both fit the model run so.
    ``fits``: a dict that receives the runs' fits without errors at the campaign's
    order, ``{run label: fit}``, when they are made.
    """
    data = cf.amplitude_model
    df = cf.amplitude_runs
    if data.error is not None or "run" not in df.columns:
        return data, None
    noise = fit_power_noise(df["A"].to_numpy(), df["power"].to_numpy(), df["run"].to_numpy(),
                            int(cf.meta["order"]), fits)
    if noise is None:
        return data, None
    return with_power_noise(data, noise, int(cf.meta["order"])), noise


def with_power_noise(data, noise, order: int):
    """``data`` (an amplitude run) with its errors from a learnt :class:`PowerNoise`: the
    noise at each point's power fitted without errors at ``order``."""
    pre = fit_amplitude(data.A, data.value, None, order)
    return dataclasses.replace(data, error=noise.sigma(pre.power(data.A)))


def with_phase_noise(data, noise):
    """``data`` (a phase run) with its errors from a learnt phase-noise model."""
    return dataclasses.replace(data, error=noise.sigma(data.A))


def phase_run_with_noise(cf):
    """The model phase run with its errors (learnt noise model when ``phase_err`` is absent,
    as :func:`model_run_with_noise`); ``(None, None)`` without a phase file."""
    data = cf.phase_model
    if data is None:
        return None, None
    df = cf.phase_runs
    if data.error is not None or "run" not in df.columns:
        return data, None
    noise = fit_phase_noise(df["A"].to_numpy(), df["phase_rad"].to_numpy(),
                            df["run"].to_numpy())
    if noise is None:
        return data, None
    return with_phase_noise(data, noise), noise
