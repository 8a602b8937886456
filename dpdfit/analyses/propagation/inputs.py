"""What a propagation starts from: the calibration's posterior, its fit and the drift; predictive draws."""

from __future__ import annotations

import numpy as np
import pandas as pd

from dpdfit.errors import InputError
from dpdfit.fits.drift import CalibrationUncertainty, DriftModel, calibration_uncertainty
from dpdfit.fits.draws import shift_y1
from dpdfit.fits.posterior import PosteriorResult

__all__ = ["resolve_calibration", "predictive_draws"]


def resolve_calibration(posterior_or_runs, order, run, seed, n_walkers, n_steps, force,
                        progress, *, fits: dict | None = None,
                        drift: DriftModel | None = None) -> CalibrationUncertainty:
    """``(posterior, lut_fit, drift or None)`` from a posterior or a multi-run table.

    A :class:`~dpdfit.fits.posterior.PosteriorResult` is used as given (its
    fit is the LUT's; the drift is ``drift``).  A runs DataFrame goes through
    :func:`dpdfit.fits.drift.calibration_uncertainty` (``fits``, ``drift``:
    precomputed per-run fits and drift model, used as given).
    """
    if isinstance(posterior_or_runs, PosteriorResult):
        return CalibrationUncertainty(posterior_or_runs, posterior_or_runs.fit, drift)
    if not isinstance(posterior_or_runs, pd.DataFrame):
        raise InputError("propagate needs a PosteriorResult or a runs DataFrame")
    return calibration_uncertainty(posterior_or_runs, order, run, seed=seed,
                                   n_walkers=n_walkers, n_steps=n_steps, force=force,
                                   progress=progress, fits=fits, drift=drift)


def predictive_draws(post, drift, stale_days, phase, draws, rng):
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
        a, _ = shift_y1(a, rng.normal(0.0, sd, size=a.shape[0]))
    db = None if phase is None else rng.multivariate_normal(
        np.zeros(len(phase.powers)), np.asarray(phase.covariance), size=a.shape[0])
    return a, db, sd
