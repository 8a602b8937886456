"""The Ramsey and spin-echo characterisation of a campaign (``ramsey.csv``).

Its physics is :mod:`dpdfit.models.ramsey` (the outcomes, and which dephasing the echo
removes), fed from the campaign's truth after the injected effects:

* the engine's arguments (:meth:`~dpdfit.simulation.injections.Injection.inject_engine`):
  white dephasing ``T2`` (independent, the lab's own among it) and ``T2_corr`` (common),
  ``G = t/T2``, never refocused; a ``dephasing_profile`` (slow or stretched noise,
  ``G = rate t_ref (t/t_ref)^beta``), refocused by the echo when ``beta > 1``; and the
  preparation and detection errors ``p_prep``, ``p_flip``, ``p_det``;
* the decay of coherences outside the gate
  (:meth:`~dpdfit.simulation.injections.Injection.inject_coherence`) at the wait itself:
  ``k1 = exp(-(G_i + G_c))``, ``k2 = exp(-2 G_i - 4 G_c)`` give the independent and
  common parts; its time profile (the exponent of ``G`` between the wait and twice it)
  says whether the echo refocuses it.

So only the effects that dephase the qubit, or change its preparation and detection (a
SPAM offset), change these recordings; heating does not.  The waits are the campaign's
grid (:func:`ramsey_waits`: zero and a geometric grid up to 1.5 times the stated T2),
both sequences at each; counts multinomial.  The campaign's own recording
(``CampaignConfig.ramsey_shots``) draws from its own random stream (purpose 21), a further
one (``("ramsey", shots)`` of ``CampaignConfig.further``) from the further item's, so that
adding either leaves every other row of the campaign as it was.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from dpdfit.models.ramsey import (SCAN_POINTS, SEQUENCES, free_dephasing,
                                  ramsey_probabilities, scan_waits)

from .config import CampaignConfig, rng_for

__all__ = ["RAMSEY_POINTS", "ramsey_waits", "ramsey_engine", "ramsey_dephasing",
           "ramsey_rows", "ramsey_table", "ramsey_truth", "RAMSEY_COLUMNS"]

#: waits per sequence of a Ramsey scan (the first at zero)
RAMSEY_POINTS = SCAN_POINTS
#: the columns the simulator writes
RAMSEY_COLUMNS = ["sequence", "wait_us", "n00", "n01_10", "n11", "shots"]


def ramsey_waits(T2: float, points: int = RAMSEY_POINTS) -> np.ndarray:
    """The waits (s) of a scan (:func:`~dpdfit.models.ramsey.scan_waits`: the menu's)."""
    return scan_waits(T2, points)


def _injections(cfg: CampaignConfig, refs: dict) -> list:
    return [(e, {**v, **{k: refs.get(k, float("nan")) for k in e.inject_refs}})
            for e, v in cfg.injections()]


def ramsey_engine(cfg: CampaignConfig, refs: dict) -> dict:
    """The engine's arguments after the injected effects (``refs``: the campaign's
    references, ``t_ref`` and ``A_ref``, as the gates get them), at the time scans'
    amplitude: no drive acts in free precession, an amplitude is only asked for."""
    kw = dict(nbar=cfg.nbar, T2=cfg.T2, T2_corr=np.inf, ndot=cfg.ndot, p_prep=cfg.p_prep,
              p_flip=0.0, p_det=cfg.p_det, power_error_db=0.0)
    for e, v in _injections(cfg, refs):
        kw = e.inject_engine(v, kw, cfg.time_scan_A)
    return kw


def _coherence_parts(cfg, refs, t) -> tuple:
    """``(G_i, G_c, slow)`` of the injected decays outside the gate at the waits ``t``
    (:meth:`~dpdfit.simulation.injections.Injection.inject_coherence`), ``slow`` per
    injection whether its ``G`` grows faster than ``t``."""
    G_i = np.zeros(t.shape)
    G_c = np.zeros(t.shape)
    parts = []
    for e, v in _injections(cfg, refs):
        probe = e.inject_coherence(v, 1e-3)
        if probe is None:
            continue
        k = [np.array([e.inject_coherence(v, float(x)) for x in tt]) for tt in (t, 2 * t)]
        with np.errstate(divide="ignore"):
            G1, G2 = (-np.log(np.clip(kk[:, 0], 1e-300, None)) for kk in k)
            Gc = -np.log(np.clip(k[0][:, 1], 1e-300, None)) / 2 - G1
        pos = G1 > 0
        beta = float(np.median(np.log2(G2[pos] / G1[pos]))) if pos.any() else 1.0
        parts.append((G1 - Gc, Gc, beta))
    return parts


def ramsey_dephasing(cfg: CampaignConfig, refs: dict, t, echo: bool) -> tuple:
    """``(G_i, G_c)``: each ion's accumulated independent and common dephasing over the
    waits ``t`` (s) of one sequence, after the injected effects (module doc)."""
    t = np.asarray(t, dtype=float)
    kw = ramsey_engine(cfg, refs)
    G_i = t / kw["T2"]
    G_c = t / kw["T2_corr"] if np.isfinite(kw.get("T2_corr", np.inf)) else np.zeros(t.shape)
    prof = kw.get("dephasing_profile")
    if prof is not None:
        rate, rate_c, beta, t_ref = (float(x) for x in prof)
        G_i = G_i + free_dephasing(rate, beta, t_ref, t, echo)
        G_c = G_c + free_dephasing(rate_c, beta, t_ref, t, echo)
    for gi, gc, beta in _coherence_parts(cfg, refs, t):
        if not (echo and beta > 1.0 + 1e-6):
            G_i, G_c = G_i + gi, G_c + gc
    return G_i, G_c


def _detection(kw: dict) -> tuple:
    det = kw["p_det"]
    return (det, det) if np.ndim(det) == 0 else (float(det[0]), float(det[1]))


def ramsey_rows(cfg: CampaignConfig, shots: int, rng: np.random.Generator, refs: dict,
                points: int = RAMSEY_POINTS) -> list:
    """The rows of one scan: each sequence at every wait of :func:`ramsey_waits`,
    ``sequence, wait_us, n00, n01_10, n11, shots``, multinomial counts from ``rng``."""
    t = ramsey_waits(cfg.T2, points)
    kw = ramsey_engine(cfg, refs)
    e01, e10 = _detection(kw)
    rows = []
    for seq in SEQUENCES:
        G_i, G_c = ramsey_dephasing(cfg, refs, t, seq == "echo")
        probs = ramsey_probabilities(G_i, G_c, float(kw["p_prep"]), float(kw.get("p_flip", 0.0)),
                                     e01, e10)
        for w, p in zip(t, probs):
            p = np.clip(p, 0.0, None)
            n = rng.multinomial(int(shots), p / p.sum())
            rows.append({"sequence": seq, "wait_us": round(float(w) * 1e6, 3),
                         "n00": int(n[0]), "n01_10": int(n[1]), "n11": int(n[2]),
                         "shots": int(shots)})
    return rows


def ramsey_table(cfg: CampaignConfig, refs: dict, further_from: int | None = None
                 ) -> pd.DataFrame:
    """``ramsey.csv`` of the campaign ``cfg``: its own scan (``ramsey_shots`` shots per
    point; none at 0), then the further ``("ramsey", shots)`` items of ``cfg.further``;
    empty when nothing records one.  ``further_from``: only the rows the further items
    from that index on add (the campaign's own left out)."""
    rows = []
    if cfg.ramsey_shots and further_from is None:
        rows += ramsey_rows(cfg, cfg.ramsey_shots, rng_for(cfg, 21), refs)
    for j, item in enumerate(cfg.further):
        if j >= (further_from or 0) and item[0] == "ramsey":
            rows += ramsey_rows(cfg, int(item[1]), rng_for(cfg, 8, j), refs)
    return pd.DataFrame(rows, columns=RAMSEY_COLUMNS)


def ramsey_truth(cfg: CampaignConfig, refs: dict) -> dict:
    """The true coherence in free precession (``truth.json``'s ``ramsey``): the white
    ``T2_s`` (independent) and ``T2_corr_s`` (common; None: none), each sequence's
    accumulated dephasing ``G_i``, ``G_c`` at the scan's waits (``waits_us``)."""
    kw = ramsey_engine(cfg, refs)
    t = ramsey_waits(cfg.T2)
    out = {"T2_s": float(kw["T2"]),
           "T2_corr_s": float(kw["T2_corr"]) if np.isfinite(kw["T2_corr"]) else None,
           "waits_us": [round(float(w) * 1e6, 3) for w in t]}
    for seq in SEQUENCES:
        G_i, G_c = ramsey_dephasing(cfg, refs, t, seq == "echo")
        out[seq] = {"G_i": [float(x) for x in G_i], "G_c": [float(x) for x in G_c]}
    return out
