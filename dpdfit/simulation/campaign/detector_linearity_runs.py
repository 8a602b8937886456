"""The detector linearity characterisation of a campaign (``detector_linearity.csv``): the
calibration photodiode read with and without a calibrated attenuator, at several drives.

Its physics is the calibration runs'
(:mod:`~dpdfit.simulation.campaign.calibration_runs`): at drive ``A`` the optical power
is the true AOM's, ``p_full eta(A)/eta_ref`` (the day's AOM, after the injected
drifts), read through the photodiode noise model of the calibration runs
(:class:`~dpdfit.simulation.aom_truth.PhotodiodeNoise`, noise before the detector's
response, as a calibration run records it) and the injected effects' photodiode
response (:meth:`~dpdfit.simulation.injections.Injection.inject_photodiode`).  The
attenuated reading is the same photodiode at the attenuated power
``10^(-ATTENUATION_DB/10) P``.  So an effect that moves the AOM (a stale table, a
drift) moves both readings alike and leaves their ratio; only a nonlinear photodiode
changes the ratio with the power.

The campaign's own characterisation (``CampaignConfig.detector_linearity_points``
drives) draws from its own random stream (purpose 13), a further one
(``("detector_linearity", points)`` of ``CampaignConfig.further``) from the further
item's, so that adding either leaves every other row of the campaign as it was.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from dpdfit.core.defaults import LINEARITY_ATTENUATION_DB
from dpdfit.recordings.detector_linearity import LOWEST_DRIVE, linearity_drives
from dpdfit.simulation.aom_truth import BraggAOM

from .config import CampaignConfig, rng_for

__all__ = ["ATTENUATION_DB", "LOWEST_DRIVE", "LINEARITY_COLUMNS", "linearity_drives",
           "detector_reading", "expected_readings", "linearity_rows", "linearity_table",
           "linearity_truth"]

#: the calibrated attenuator's attenuation (dB), the lab's default
#: (:data:`~dpdfit.core.defaults.LINEARITY_ATTENUATION_DB`)
ATTENUATION_DB = LINEARITY_ATTENUATION_DB
#: the columns the simulator writes (``power_err``: 1-sigma of ``power``)
LINEARITY_COLUMNS = ("A", "power", "power_attenuated", "attenuation_db", "power_err")


def detector_reading(cfg: CampaignConfig, power) -> np.ndarray:
    """The calibration photodiode's reading of ``power`` (the injected effects'
    ``inject_photodiode``, in order, as the calibration runs apply them)."""
    read = np.asarray(power, dtype=float)
    for e, v in cfg.injections():
        read = e.inject_photodiode(v, read, cfg.photodiode.p_full)
    return read


def expected_readings(cfg: CampaignConfig, aom: BraggAOM, A) -> tuple:
    """The noiseless ``(power, power_attenuated)`` at drives ``A`` of the AOM ``aom``."""
    p = cfg.photodiode.p_full * aom.efficiency(np.asarray(A, dtype=float)) / aom.eta_ref
    r = 10.0 ** (-ATTENUATION_DB / 10.0)
    return detector_reading(cfg, p), detector_reading(cfg, r * p)


def linearity_rows(cfg: CampaignConfig, aom: BraggAOM, points: int,
                   rng: np.random.Generator) -> pd.DataFrame:
    """One row per drive of :func:`linearity_drives`: both readings with the calibration
    runs' photodiode noise drawn from ``rng`` (the plain reading's noise first)."""
    A = linearity_drives(points)
    p = cfg.photodiode.p_full * aom.efficiency(A) / aom.eta_ref
    pa = 10.0 ** (-ATTENUATION_DB / 10.0) * p
    sig, sig_a = cfg.photodiode.sigma(p), cfg.photodiode.sigma(pa)
    noise = rng.standard_normal((2, A.size))
    return pd.DataFrame({"A": A, "power": detector_reading(cfg, p + sig * noise[0]),
                         "power_attenuated": detector_reading(cfg, pa + sig_a * noise[1]),
                         "attenuation_db": ATTENUATION_DB, "power_err": sig})


def linearity_table(cfg: CampaignConfig, aom: BraggAOM,
                    further_from: int | None = None) -> pd.DataFrame:
    """``detector_linearity.csv`` of the campaign ``cfg`` (``aom``: the day's true AOM,
    :func:`~.calibration_runs.calibration_runs`): its own characterisation
    (``detector_linearity_points`` drives; none at 0), then the further
    ``("detector_linearity", points)`` items of ``cfg.further``; empty when nothing
    records it.  ``further_from``: only the rows the further items from that index on
    add (the campaign's own left out)."""
    parts = []
    if cfg.detector_linearity_points and further_from is None:
        parts.append(linearity_rows(cfg, aom, cfg.detector_linearity_points, rng_for(cfg, 13)))
    for j, item in enumerate(cfg.further):
        if j >= (further_from or 0) and item[0] == "detector_linearity":
            parts.append(linearity_rows(cfg, aom, int(item[1]), rng_for(cfg, 8, j)))
    if not parts:
        return pd.DataFrame(columns=list(LINEARITY_COLUMNS))
    return pd.concat(parts, ignore_index=True)


def linearity_truth(cfg: CampaignConfig) -> dict:
    """``truth.json``'s ``detector_linearity``: the attenuation, and the relative change of
    the readings' ratio at full scale against the attenuator's transmission (0 for a
    linear photodiode)."""
    r = 10.0 ** (-ATTENUATION_DB / 10.0)
    full = cfg.photodiode.p_full
    ratio = detector_reading(cfg, np.array([r * full]))[0] / detector_reading(
        cfg, np.array([full]))[0]
    return {"attenuation_db": ATTENUATION_DB, "ratio_change_at_full_scale": float(ratio / r - 1)}
