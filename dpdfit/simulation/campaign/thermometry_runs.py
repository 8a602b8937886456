"""The sideband thermometry of a campaign (``thermometry.csv``): the gate mode cooled, left
to heat for a wait, probed on its red or blue sideband, the probed ion read out.

Its physics is :mod:`dpdfit.models.sideband_thermometry` (the thermal average of the
sideband Rabi flopping of a fixed probe pulse, with the preparation and detection
errors), at the mean occupation ``nbar + ndot t`` of the gate engine's own ``nbar`` and
``ndot`` after the injected effects
(:meth:`~dpdfit.simulation.injections.Injection.inject_engine`: heating and extra
initial phonons change them) and its preparation and detection errors
(:func:`~dpdfit.simulation.campaign.spam_runs.spam_engine`: a SPAM offset changes them).
The counts are binomial.  The campaign's own recording (``CampaignConfig.thermometry_shots``)
draws from its own random stream (purpose 14), a further one (``("thermometry", shots)``
of ``CampaignConfig.further``) from the further item's, so that adding either leaves
every other row of the campaign as it was.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from dpdfit.models.sideband_thermometry import (SIDEBANDS, THERMOMETRY_WAITS_US,
                                                bright_probability, mean_occupation)

from .config import CampaignConfig, rng_for
from .spam_runs import spam_engine

__all__ = ["THERMOMETRY_WAITS_US", "THERMOMETRY_PURPOSE", "thermometry_engine",
           "thermometry_rows", "thermometry_table", "thermometry_truth"]

# THERMOMETRY_WAITS_US: the waits a recording probes (the menu's, one definition)
#: the random stream of the campaign's own thermometry (:func:`~.config.rng_for`)
THERMOMETRY_PURPOSE = 14


def thermometry_engine(cfg: CampaignConfig) -> dict:
    """``nbar`` (quanta) and ``ndot`` (quanta/s) of the gate mode after the injected
    effects, with the preparation and detection errors ``p_prep``, ``p_flip``, ``e01``,
    ``e10`` (:func:`~.spam_runs.spam_engine`).  As there, the gates' references are NaN:
    the thermometry precedes any gate."""
    kw = dict(nbar=cfg.nbar, T2=cfg.T2, T2_corr=np.inf, ndot=cfg.ndot, p_prep=cfg.p_prep,
              p_flip=0.0, p_det=cfg.p_det, power_error_db=0.0)
    for e, v in cfg.injections():
        kw = e.inject_engine({**v, **{k: float("nan") for k in e.inject_refs}}, kw,
                             cfg.time_scan_A)
    return {"nbar": float(kw["nbar"]), "ndot": float(kw["ndot"]), **spam_engine(cfg)}


def thermometry_rows(cfg: CampaignConfig, shots: int, rng: np.random.Generator,
                     waits_us=THERMOMETRY_WAITS_US) -> list:
    """One row per wait of ``waits_us`` and sideband (red, then blue): ``wait_us,
    sideband, n_bright, shots``, binomial counts of ``shots`` drawn from ``rng``."""
    e = thermometry_engine(cfg)
    w = np.repeat(np.asarray(waits_us, dtype=float), len(SIDEBANDS))
    sb = np.tile(np.asarray(SIDEBANDS), len(waits_us))
    p = bright_probability(mean_occupation(e["nbar"], e["ndot"], w * 1e-6), sb,
                           e["p_prep"], e["p_flip"], e["e01"], e["e10"])
    n = rng.binomial(int(shots), np.clip(p, 0.0, 1.0))
    return [{"wait_us": float(a), "sideband": str(b), "n_bright": int(c), "shots": int(shots)}
            for a, b, c in zip(w, sb, n)]


def thermometry_table(cfg: CampaignConfig, further_from: int | None = None) -> pd.DataFrame:
    """``thermometry.csv`` of the campaign ``cfg``: its own recording
    (``thermometry_shots`` per wait and sideband; none at 0), then the further
    ``("thermometry", shots)`` items of ``cfg.further``; empty when nothing records it.
    ``further_from``: only the rows the further items from that index on add."""
    rows = []
    if cfg.thermometry_shots and further_from is None:
        rows += thermometry_rows(cfg, cfg.thermometry_shots, rng_for(cfg, THERMOMETRY_PURPOSE))
    for j, item in enumerate(cfg.further):
        if j >= (further_from or 0) and item[0] == "thermometry":
            rows += thermometry_rows(cfg, int(item[1]), rng_for(cfg, 8, j))
    return pd.DataFrame(rows, columns=["wait_us", "sideband", "n_bright", "shots"])


def thermometry_truth(cfg: CampaignConfig) -> dict:
    """The true motional state (``truth.json``'s ``thermometry``): ``nbar`` (quanta,
    after cooling) and ``heating_quanta_per_s``."""
    e = thermometry_engine(cfg)
    return {"nbar": e["nbar"], "heating_quanta_per_s": e["ndot"]}
