"""Distribution of the threshold efficiencies eta_th(eps) over the calibration's uncertainty."""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.sweep import first_crossing_rows
from dpdfit.core.defaults import AMPLITUDE_ORDER, ETA_REF, FORMULA, NBAR, NU_HZ, XI0_SPECTRA_HZ
from dpdfit.fits.draws import quantile_summary
from dpdfit.fits.drift import DriftModel

from .forward import BatchedForwardModel
from .inputs import predictive_draws, resolve_calibration

__all__ = ["threshold_distribution"]


def _threshold_summary(th) -> dict:
    """Quantiles of the per-draw thresholds ``th`` (NaN: not reached), or ``median: None``
    when fewer than half of the draws reach the level."""
    ok = np.isfinite(th)
    if ok.mean() >= 0.5:
        row = {k: float(v) for k, v in quantile_summary(th[ok]).items()}
        row["fraction_reached"] = float(ok.mean())
        return row
    return {"median": None, "fraction_reached": float(ok.mean())}


def threshold_distribution(posterior_or_runs, stale_days: float = 0.0, draws: int = 2000, *,
                           amplitudes=None, levels=(1e-2, 1e-3, 1e-4), phase=None, run=None,
                           seed=None, order: int = AMPLITUDE_ORDER, n_walkers: int = 32,
                           n_steps: int = 400, force: bool = False,
                           drift: DriftModel | None = None, fits: dict | None = None,
                           nu: float = NU_HZ, xi0: float = XI0_SPECTRA_HZ, nbar: float = NBAR,
                           formula: str = FORMULA, eta_ref: float = ETA_REF) -> dict:
    """Distribution of the threshold efficiencies ``eta_th(eps)`` and ``eta_bar_corr``.

    Every predictive draw of the true transfer function (as in
    :func:`dpdfit.analyses.propagation.propagate`, including the Gaussian
    posterior of the phase polynomial when ``phase`` is given) is pushed through
    the sweep on an amplitude grid (default 40 points on 0.05..1) for both
    flags, with the predistortion table of the calibration; per draw,
    ``eta_th`` is the first rise of ``eps_est`` through each level in log-log
    interpolation (as :func:`dpdfit.analyses.sweep.thresholds`).  Returns, per
    flag and level, the median and the 68 % / 95 % intervals over the draws
    (``null`` entries when fewer than half of the draws reach the level), and
    the fraction of draws that reach it.  ``drift`` and ``fits``: precomputed
    drift model and per-run fits, as for ``propagate``.
    """
    amplitudes = np.linspace(0.05, 1.0, 40) if amplitudes is None else np.asarray(amplitudes)
    post, fit0, drift = resolve_calibration(posterior_or_runs, order, run, seed, n_walkers,
                                            n_steps, force, False, fits=fits, drift=drift)
    a, db, _ = predictive_draws(post, drift, stale_days, phase, draws,
                                np.random.default_rng(None if seed is None else seed + 2))
    # one model per amplitude serves both flags (it holds both tables' responses)
    models = [BatchedForwardModel(fit0, phase, float(A), nu, xi0, nbar, formula, eta_ref)
              for A in amplitudes]
    out = {}
    for dpd, key in ((1, "dpd"), (0, "no_dpd")):
        eps = np.empty((a.shape[0], amplitudes.size))
        eta = np.empty_like(eps)
        for j, model in enumerate(models):
            r = model.evaluate(a, dpd, db)
            eps[:, j] = 1.0 - r["F_est"]
            eta[:, j] = r["eta_bar"]
        out[key] = {f"{lev:.0e}".replace("e-0", "e-"):
                    _threshold_summary(first_crossing_rows(eta, eps, lev)) for lev in levels}
    out.update({"stale_days": float(stale_days), "draws": int(draws),
                "amplitudes": [float(v) for v in amplitudes]})
    return out
