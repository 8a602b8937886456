"""The SPAM characterisation of a campaign (``spam.csv``): basis states prepared and
detected with no gate.

Its physics is the gate engine's preparation and detection (:mod:`dpdfit.models.gate_sim.spam`):
each ion is independently a *spectator* with probability ``p_prep`` (a level outside the
qubit, driven by no pulse, reads bright ``0``), in the wrong qubit state with
probability ``p_flip``, right otherwise; each ion's reading is flipped with the
detection errors ``p_det`` (``(e01, e10)``: bright read dark, dark read bright).  A
state ``|1>`` is prepared from ``|0>`` by a pi pulse, which leaves a spectator bright
and takes a flipped ion to ``0``.  So a prepared ``0`` reads dark with probability
``p_flip (1 - e10) + (1 - p_flip) e01``, a prepared ``1`` with ``(1 - p_prep - p_flip)
(1 - e10) + (p_prep + p_flip) e01`` (:func:`spam_probabilities`).

The injected effects act through the engine's arguments
(:meth:`~dpdfit.simulation.injections.Injection.inject_engine`): only those that change
``p_prep``, ``p_flip`` or ``p_det`` (a SPAM offset) change these recordings; the counts
are multinomial.  The campaign's own SPAM recording (``CampaignConfig.spam_shots``)
draws from its own random stream (purpose 9), a further one (``("spam", shots)`` of
``CampaignConfig.further``) from the further item's, so that adding either leaves
every other row of the campaign as it was.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from .config import CampaignConfig, rng_for

__all__ = ["SPAM_STATES", "spam_engine", "spam_probabilities", "spam_rows", "spam_table",
           "spam_truth"]

#: the basis states a SPAM recording prepares, one row each
SPAM_STATES = ("00", "11")


def spam_engine(cfg: CampaignConfig) -> dict:
    """``p_prep``, ``p_flip`` and ``(e01, e10)`` of the campaign's preparation and
    detection: the configuration's, changed by the injected effects.  Preparation
    precedes any gate, so the gates' references (``inject_refs``) are given as NaN: an
    effect whose preparation depended on them would show NaN, not a number of a gate."""
    kw = dict(nbar=cfg.nbar, T2=cfg.T2, T2_corr=np.inf, ndot=cfg.ndot, p_prep=cfg.p_prep,
              p_flip=0.0, p_det=cfg.p_det, power_error_db=0.0)
    A = cfg.time_scan_A
    for e, v in cfg.injections():
        kw = e.inject_engine({**v, **{k: float("nan") for k in e.inject_refs}}, kw, A)
    det = kw["p_det"]
    e01, e10 = (det, det) if np.ndim(det) == 0 else (float(det[0]), float(det[1]))
    return {"p_prep": float(kw["p_prep"]), "p_flip": float(kw.get("p_flip", 0.0)),
            "e01": float(e01), "e10": float(e10)}


def spam_probabilities(p_prep: float, p_flip: float, e01: float, e10: float,
                       states=SPAM_STATES) -> np.ndarray:
    """Detected ``(P00, P01_10, P11)`` of each prepared state in ``states`` (rows):
    the ions independent, each read dark (``1``) with the probability of the module doc."""
    dark0 = p_flip * (1 - e10) + (1 - p_flip) * e01
    dark1 = (1 - p_prep - p_flip) * (1 - e10) + (p_prep + p_flip) * e01
    out = []
    for s in states:
        a, b = (dark1 if c == "1" else dark0 for c in s)
        out.append(((1 - a) * (1 - b), a * (1 - b) + (1 - a) * b, a * b))
    return np.asarray(out, dtype=float)


def spam_rows(cfg: CampaignConfig, shots: int, rng: np.random.Generator,
              states=SPAM_STATES) -> list:
    """One row per prepared state of ``states``: ``prepared, n00, n01_10, n11, shots``,
    multinomial counts of ``shots`` drawn from ``rng``."""
    e = spam_engine(cfg)
    probs = spam_probabilities(e["p_prep"], e["p_flip"], e["e01"], e["e10"], states)
    rows = []
    for s, p in zip(states, probs):
        n = rng.multinomial(int(shots), np.clip(p, 0.0, None) / np.clip(p, 0.0, None).sum())
        rows.append({"prepared": s, "n00": int(n[0]), "n01_10": int(n[1]),
                     "n11": int(n[2]), "shots": int(shots)})
    return rows


def spam_table(cfg: CampaignConfig, further_from: int | None = None) -> pd.DataFrame:
    """``spam.csv`` of the campaign ``cfg``: its own SPAM recording (``spam_shots``
    shots per state; none at 0), then the further ``("spam", shots)`` items of
    ``cfg.further``; empty when nothing records SPAM.  ``further_from``: only the rows
    the further items from that index on add (the campaign's own left out)."""
    rows = []
    if cfg.spam_shots and further_from is None:
        rows += spam_rows(cfg, cfg.spam_shots, rng_for(cfg, 9))
    for j, item in enumerate(cfg.further):
        if j >= (further_from or 0) and item[0] == "spam":
            rows += spam_rows(cfg, int(item[1]), rng_for(cfg, 8, j))
    return pd.DataFrame(rows, columns=["prepared", "n00", "n01_10", "n11", "shots"])


def spam_truth(cfg: CampaignConfig) -> dict:
    """The true preparation and detection errors per ion (``truth.json``'s ``spam``):
    ``spectator`` (``p_prep``), ``flip``, ``e01``, ``e10``."""
    e = spam_engine(cfg)
    return {"spectator": e["p_prep"], "flip": e["p_flip"], "e01": e["e01"], "e10": e["e10"]}
