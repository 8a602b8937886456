"""The recalibration question: which drift of y(1) costs a given F_est, and when to expect it."""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from dpdfit.core.defaults import FORMULA, NBAR, NU_HZ, XI0_SPECTRA_HZ
from dpdfit.errors import InputError
from dpdfit.fits.calibration import AmplitudeCalibration, PhaseCalibration
from dpdfit.fits.draws import shift_y1
from dpdfit.fits.drift import DriftModel

from .forward import BatchedForwardModel

__all__ = ["recalibration"]

#: Largest ``|delta y(1)|`` searched, and the grid of trial shifts towards it.
_DELTA_GRID = np.geomspace(1e-6, 0.2, 60)


def _first_root(lossf, sign):
    """Smallest shift of sign ``sign`` at which ``lossf`` reaches 0 (None if never)."""
    grid = sign * _DELTA_GRID
    vals = np.array([lossf(d) for d in grid])
    hit = np.flatnonzero(vals >= 0)
    if hit.size == 0:
        return None
    i = hit[0]
    lo = 0.0 if i == 0 else grid[i - 1]
    return float(brentq(lossf, lo, grid[i], xtol=1e-12))


def recalibration(calibration: AmplitudeCalibration, A: float, loss: float = 1e-4, *,
                  drift: DriftModel | None = None, phase: PhaseCalibration | None = None,
                  nu: float = NU_HZ, xi0: float = XI0_SPECTRA_HZ, nbar: float = NBAR,
                  formula: str = FORMULA, forward: BatchedForwardModel | None = None) -> dict:
    """Drift of ``y(1)`` that costs ``loss`` in ``F_est(A, DPD)``, and when to expect it.

    The LUT comes from ``calibration``; the true transfer function is the same
    polynomial with ``y(1)`` moved by ``delta`` (nonlinear part scaled, see
    :func:`dpdfit.fits.draws.shift_y1`).  Returns ``{"delta_y1", "delta_plus",
    "delta_minus", "loss", "A", "F_est_calibrated", "days_until", "sigma_drift",
    "rate_per_day"}``: ``delta_y1`` is the smaller in magnitude of the two signed
    solutions (``None`` where a sign never reaches the loss within ``|delta| <= 0.2``),
    and ``days_until`` the staleness at which the drift model's ``sigma_drift(d)``
    reaches ``|delta_y1|`` (``None``: never).  ``forward``: the forward model of
    ``calibration``, ``phase`` and ``A`` if already built.
    """
    if not loss > 0:
        raise InputError(f"fidelity loss must be > 0, got {loss}")
    fw = forward or BatchedForwardModel(calibration, phase, A, nu, xi0, nbar, formula)
    a0 = np.asarray(calibration.coefficients)[None, :]
    F0 = float(fw.evaluate(a0, 1)["F_est"][0])

    def lossf(delta):
        a, _ = shift_y1(a0, np.array([delta]))
        return F0 - float(fw.evaluate(a, 1)["F_est"][0]) - loss

    sols = {"delta_plus": _first_root(lossf, 1), "delta_minus": _first_root(lossf, -1)}
    cands = [v for v in sols.values() if v is not None]
    delta = min(cands, key=abs) if cands else None
    days = None
    if delta is not None and drift is not None:
        days = drift.days_until(delta)
    return {"delta_y1": delta, **sols, "loss": float(loss), "A": float(A),
            "F_est_calibrated": F0, "days_until": days,
            "sigma_drift": None if drift is None else drift.sigma_drift,
            "rate_per_day": None if drift is None else drift.rate_per_day}
