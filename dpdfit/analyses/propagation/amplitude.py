"""Distribution of F_est, R10 and eta_bar at one amplitude: :func:`propagate`."""

from __future__ import annotations

import math
import time

import numpy as np

from dpdfit.core.defaults import AMPLITUDE_ORDER, ETA_REF, FORMULA, NBAR, NU_HZ, XI0_SPECTRA_HZ
from dpdfit.errors import InputError
from dpdfit.fits.calibration import AmplitudeCalibration, PhaseCalibration
from dpdfit.fits.draws import read_only
from dpdfit.fits.drift import DriftModel

from .forward import BatchedForwardModel
from .inputs import predictive_draws, resolve_calibration
from .recalibration import recalibration
from .result import PropagationResult

__all__ = ["propagate"]


def propagate(posterior_or_runs, A: float, stale_days: float = 0.0, draws: int = 10000, *,
              phase: PhaseCalibration | None = None, lut_fit: AmplitudeCalibration | None = None,
              drift: DriftModel | None = None, fits: dict | None = None,
              order: int = AMPLITUDE_ORDER, run=None, seed=None,
              n_walkers: int = 32, n_steps: int = 400, force: bool = False,
              progress: bool | None = None, nu: float = NU_HZ, xi0: float = XI0_SPECTRA_HZ,
              nbar: float = NBAR, formula: str = FORMULA, eta_ref: float = ETA_REF,
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
        Required when ``stale_days > 0`` and a posterior is given; with a runs
        table it replaces the drift model of the runs.
    fits : dict, optional
        Precomputed per-run fits of the runs table
        (:func:`dpdfit.fits.drift.fit_runs`); same numbers, no refit.
    recalibration_loss : float, optional
        Also answer :func:`recalibration` for this fidelity loss.
    progress : bool, optional
        A bar over the emcee steps; default: when stderr is a terminal.
    """
    t0 = time.perf_counter()
    A = float(A)
    if not 0 < A <= 1:
        raise InputError(f"A must lie in (0, 1], got {A}")
    if draws < 1:
        raise InputError(f"draws must be >= 1, got {draws}")
    if not (math.isfinite(stale_days) and stale_days >= 0):
        raise InputError(f"stale_days must be a finite number >= 0, got {stale_days}")
    post, fit0, drift = resolve_calibration(posterior_or_runs, order, run, seed, n_walkers,
                                            n_steps, force, progress, fits=fits, drift=drift)
    lut_fit = lut_fit or fit0
    a, db, sd = predictive_draws(post, drift, stale_days, phase, draws,
                                 np.random.default_rng(None if seed is None else seed + 1))
    fw = BatchedForwardModel(lut_fit, phase, A, nu, xi0, nbar, formula, eta_ref)
    samples, point = {}, {}
    for dpd, key in ((1, "dpd"), (0, "no_dpd")):
        parts = [fw.evaluate(a[i:i + chunk], dpd, None if db is None else db[i:i + chunk])
                 for i in range(0, a.shape[0], chunk)]
        samples[key] = {k: read_only(np.concatenate([p[k] for p in parts])) for k in parts[0]}
        pt = fw.evaluate(np.asarray(lut_fit.coefficients)[None, :], dpd)
        point[key] = {k: float(v[0]) for k, v in pt.items()}
    rc = None
    if recalibration_loss is not None:
        rc = recalibration(lut_fit, A, recalibration_loss, drift=drift, phase=phase,
                           forward=fw)
    return PropagationResult(A=A, stale_days=float(stale_days), n_draws=int(draws),
                             sigma_drift=sd, samples=samples, point=point,
                             tau=post.tau_max, n_independent=post.n_independent,
                             wall_time=time.perf_counter() - t0, recalibration=rc)
