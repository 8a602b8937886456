"""Gate recordings of a campaign: populations, parity scans, gate rates and time scans.

Each setting (gate amplitude, DPD flag) drives the exact gate engine
(:mod:`dpdfit.models.gate_sim`) with the optical tones the day's AOM
produces; its ``xi0`` is calibrated with a relative error, and every scan
carries a laser-power jitter (an injected effect may add a systematic offset).
Injected effects change the engine's inputs (``Injection.inject_engine``) and may decay
the final state's coherences before the analysis pulse (``Injection.inject_coherence``);
those that need the campaign's reference amplitude or gate time get them as the
diagnosis's gate model defines them (``Injection.inject_refs``).  All draws
come from one random stream (purpose 5), in a fixed order; the ``further``
scans and time scans (:attr:`CampaignConfig.further`) come after, each from
its own stream, so that adding one leaves every other row as it was.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from dpdfit.core.defaults import ERROR_MODEL
from dpdfit.models import gate_sim

from .config import CampaignConfig, rng_for
from .further_engine import FurtherEngine, jittered_scan_counts
from .optics import gate_spectrum

__all__ = ["gate_tables", "further_gate_rows", "gate_references"]

_PHASES = ERROR_MODEL.analysis_phases()           # analysis phases of the parity scans
_SCAN_SHOTS = 625                                  # shots per time-scan point


def _t2(cfg) -> float:
    # 1 / (1 / T2): the bundled campaigns were drawn with it (extra dephasing is injected)
    return 1.0 / (1.0 / cfg.T2)


def _references(cfg, spectra: dict, eta_Omega0: float) -> dict:
    """The campaign's reference values an injection may read (``Injection.inject_refs``), as
    the diagnosis's gate model defines them: ``A_ref``, the mean amplitude of the gate
    settings, and ``t_ref``, their median gate time (here the nominal one, ``1/xi0`` of
    the exact calibration, known before any rate is drawn)."""
    t = [1.0 / gate_sim.calibrate_xi0(b, c, n, eta_Omega0) for n, b, c in spectra.values()]
    return {"A_ref": float(np.mean([A for A, _ in spectra])), "t_ref": float(np.median(t))}


def _injections(cfg, refs: dict) -> list:
    """The injected effects with their values, the references they read added."""
    return [(e, {**v, **{k: refs[k] for k in e.inject_refs}}) for e, v in cfg.injections()]


def _engine(cfg, A: float, power_error_db: float, refs: dict) -> dict:
    """The gate engine's physical inputs at a setting of amplitude ``A``: the
    configuration's, changed by the injected effects (``Injection.inject_engine``)."""
    kw = dict(nbar=cfg.nbar, T2=_t2(cfg), T2_corr=np.inf, ndot=cfg.ndot, p_prep=cfg.p_prep,
              p_flip=0.0, p_det=cfg.p_det, power_error_db=power_error_db)
    for e, v in _injections(cfg, refs):
        kw = e.inject_engine(v, kw, A)
    return kw


def _after_gate(cfg, t_gate: float, refs: dict) -> dict:
    """The engine's argument for the decay of the final state's coherences after a gate
    of ``t_gate`` (s) by the injected effects (``Injection.inject_coherence``): ``{}`` when
    none decays them, so the engine runs exactly as without."""
    k1 = k2 = 1.0
    found = False
    for e, v in _injections(cfg, refs):
        k = e.inject_coherence(v, t_gate)
        if k is not None:
            k1, k2, found = k1 * float(k[0]), k2 * float(k[1]), True
    return {"coherence": (k1, k2)} if found else {}


def _setting_scans(cfg, rng, eta_Omega0, A, d, n, b, c, out, p, refs):
    """Gate rate, population and parity scans of one setting: rows appended to ``out``."""
    xi_true = gate_sim.calibrate_xi0(b, c, n, eta_Omega0)
    xi_cal = xi_true * (1 + cfg.xi0_rel_err * rng.standard_normal())
    out["rates"].append({"A": A, "dpd": d, "xi0_khz": xi_cal / 1e3,
                         "xi0_err_khz": cfg.xi0_rel_err * xi_cal / 1e3})
    fids = []
    fids_gate, fids_app = [], []
    for s, (shots_pop, shots_par) in enumerate(cfg.scan_shots):
        eps_db = cfg.power_jitter_db * rng.standard_normal()
        res = gate_sim.simulate_setting(b, c, n, eta_Omega0, xi_cal, parity_phases=_PHASES,
                                        **_engine(cfg, A, eps_db, refs),
                                        **_after_gate(cfg, 1.0 / xi_cal, refs))
        counts = res.sample(rng, shots_pop, shots_par)
        out["pop"].append({"A": A, "dpd": d, "scan": s + 1, "n00": counts["n00"],
                           "n01_10": counts["n01_10"], "n11": counts["n11"],
                           "n_even": counts["n00"] + counts["n11"], "shots": shots_pop})
        for ph, k in zip(_PHASES, counts["parity_even"]):
            out["par"].append({"A": A, "dpd": d, "scan": s + 1, "phase_rad": float(ph),
                               "n_even": int(k), "shots": shots_par})
        fids.append(res.fidelity_max)
        fids_gate.append(res.fidelity_gate)
        fids_app.append(res.apparent_fidelity)
        p.update()
    out["truth"].append({"A": A, "dpd": d, "xi0_true_hz": xi_true, "xi0_cal_hz": xi_cal,
                         "bell_fidelity_mean_over_scans": float(np.mean(fids)),
                         "gate_only_fidelity_mean_over_scans": float(np.mean(fids_gate)),
                         "apparent_fidelity_mean_over_scans": float(np.mean(fids_app))})


def _time_scan(cfg, rng, eta_Omega0, d, n, b, c, out, refs, A=None, shots=_SCAN_SHOTS,
               points=None, engine=None):
    """Time scan at ``A`` (``cfg.time_scan_A``) of one flag: rows appended to ``out["time"]``
    (``engine``: a further recording's, which runs a repeated time scan once)."""
    A = cfg.time_scan_A if A is None else A
    points = cfg.time_scan_points if points is None else points
    xi_cal = next(r["xi0_khz"] for r in out["rates"] if r["A"] == A and r["dpd"] == d) * 1e3
    t = np.linspace(0, cfg.time_scan_max / xi_cal, points)
    # a time scan is a gate run: it carries any injected power offset
    # (no per-scan jitter is drawn, which keeps older campaigns' bytes); a decay of the
    # final coherences leaves its populations alone
    if engine is not None:
        res = engine.time_scan(A, d, xi_cal, t)
    else:
        res = gate_sim.simulate_setting(b, c, n, eta_Omega0, xi_cal, parity_phases=_PHASES,
                                        scan_times=t, **_engine(cfg, A, 0.0, refs))
    counts = res.sample(rng, 0, 0, shots_scan=shots)
    for ti, cnt in zip(t, counts.scan_counts):
        out["time"].append({"A": A, "dpd": d, "t_us": ti * 1e6, "n00": int(cnt[0]),
                            "n01_10": int(cnt[1]), "n11": int(cnt[2]), "shots": shots})


def _rate(cfg, rng, eta_Omega0, A, d, n, b, c, out) -> None:
    """The gate-rate calibration of a further recording's setting, unless it has one
    (a new setting's ``xi0`` is calibrated, with its error, and recorded)."""
    if any(r["A"] == A and r["dpd"] == d for r in out["rates"]):
        return
    xi_cal = gate_sim.calibrate_xi0(b, c, n, eta_Omega0) * (
        1 + cfg.xi0_rel_err * rng.standard_normal())
    out["rates"].append({"A": A, "dpd": d, "xi0_khz": xi_cal / 1e3,
                         "xi0_err_khz": cfg.xi0_rel_err * xi_cal / 1e3})


def _further_scan(rng, engine, A, d, shots_pop, shots_par, out, sigma_db) -> None:
    """One further scan of a setting (the next scan label there): population rows if
    ``shots_pop``, parity rows if ``shots_par``; a scan of no shots writes no rows."""
    label = 1 + max((r["scan"] for r in out["pop"] + out["par"]
                     if r["A"] == A and r["dpd"] == d), default=0)
    eps_db = sigma_db * rng.standard_normal()
    counts = engine.scan(A, d, eps_db).sample(rng, shots_pop, shots_par)
    if shots_pop:
        out["pop"].append({"A": A, "dpd": d, "scan": label, "n00": counts["n00"],
                           "n01_10": counts["n01_10"], "n11": counts["n11"],
                           "n_even": counts["n00"] + counts["n11"], "shots": shots_pop})
    if shots_par:
        for ph, k in zip(_PHASES, counts["parity_even"]):
            out["par"].append({"A": A, "dpd": d, "scan": label, "phase_rad": float(ph),
                               "n_even": int(k), "shots": shots_par})


def _further_gates(cfg, aom, lut, eta_Omega0, out, refs, first: int = 0) -> dict:
    """The ``further`` scans and time scans, each from its own stream, appended to ``out``
    (the engine's outcomes shared between the scans of a setting: :mod:`.further_engine`).
    Returns the lengths of ``out``'s lists before item ``first`` (where its rows begin)."""
    spectra = {}

    def run(A, d, eps_db, scan_times=None):
        n, b, c = spectra[(A, d)]
        xi_cal = next(r["xi0_khz"] for r in out["rates"] if r["A"] == A and r["dpd"] == d) * 1e3
        if scan_times is not None:          # a time scan: no jitter, no coherence decay
            return gate_sim.simulate_setting(b, c, n, eta_Omega0, xi_cal,
                                             parity_phases=_PHASES, scan_times=scan_times,
                                             **_engine(cfg, A, 0.0, refs))
        return gate_sim.simulate_setting(b, c, n, eta_Omega0, xi_cal, parity_phases=_PHASES,
                                         **_engine(cfg, A, eps_db, refs),
                                         **_after_gate(cfg, 1.0 / xi_cal, refs))

    engine = FurtherEngine(jittered_scan_counts(cfg.further), cfg.power_jitter_db, run)
    start = None
    for j, item in enumerate(cfg.further):
        if j == first:
            start = {k: len(v) for k, v in out.items()}
        if item[0] not in ("scan", "time_scan"):
            continue
        rng = rng_for(cfg, 8, j)
        A, d = float(item[1]), int(item[2])
        if (A, d) not in spectra:
            spectra[(A, d)] = gate_spectrum(cfg, aom, lut, A, d)
        n, b, c = spectra[(A, d)]
        _rate(cfg, rng, eta_Omega0, A, d, n, b, c, out)
        if item[0] == "scan":
            _further_scan(rng, engine, A, d, int(item[3]), int(item[4]), out,
                          cfg.power_jitter_db)
        else:
            _time_scan(cfg, rng, eta_Omega0, d, n, b, c, out, refs, A=A, shots=int(item[3]),
                       points=int(item[4]), engine=engine)
    return start if start is not None else {k: len(v) for k, v in out.items()}


def _gate_setup(cfg: CampaignConfig, aom, lut):
    """The gate settings, their optical spectra, ``eta_Omega0`` and the references."""
    settings = [(A, d) for A in cfg.gate_amplitudes for d in (0, 1)]
    spectra = {s: gate_spectrum(cfg, aom, lut, *s) for s in settings}
    # eta*Omega0 such that the anchor (A=0.4, no DPD) calibrates to alpha
    n0, b0, c0 = gate_spectrum(cfg, aom, lut, 0.4, 0)
    xi_unit = gate_sim.calibrate_xi0(b0, c0, n0, 1.0)
    eta_Omega0 = cfg.alpha_khz * 1e3 / xi_unit
    return settings, spectra, eta_Omega0, _references(cfg, spectra, eta_Omega0)


def gate_references(cfg: CampaignConfig, aom, lut) -> dict:
    """The campaign's references the injections read (``A_ref``, ``t_ref``), as the gates
    get them: for a recording without a gate (a characterisation) whose injected physics
    is parametrised at the gate time."""
    return _gate_setup(cfg, aom, lut)[3]


def _frames(out: dict, start: dict | None = None) -> tuple:
    start = start or {}
    return tuple(pd.DataFrame(out[k][start.get(k, 0):]) for k in ("pop", "par", "rates", "time"))


def gate_tables(cfg: CampaignConfig, aom, lut, progress):
    """``populations.csv``, ``parity.csv``, ``gate_rates.csv``, ``time_scans.csv`` tables
    and the gates' truth (``eta_Omega0`` and per-setting true/calibrated ``xi0``, fidelities)."""
    rng = rng_for(cfg, 5)
    settings, spectra, eta_Omega0, refs = _gate_setup(cfg, aom, lut)
    out = {"pop": [], "par": [], "rates": [], "time": [], "truth": []}
    with progress("gate experiments", len(settings) * len(cfg.scan_shots) + 2) as p:
        for (A, d) in settings:
            _setting_scans(cfg, rng, eta_Omega0, A, d, *spectra[(A, d)], out, p, refs)
        for d in (0, 1):
            _time_scan(cfg, rng, eta_Omega0, d, *spectra[(cfg.time_scan_A, d)], out, refs)
            p.update()
    _further_gates(cfg, aom, lut, eta_Omega0, out, refs)
    return (*_frames(out), {"eta_Omega0": eta_Omega0, "settings": out["truth"]})


def further_gate_rows(cfg: CampaignConfig, aom, lut, first: int, progress) -> tuple:
    """The rows of ``populations``, ``parity``, ``gate_rates`` and ``time_scans`` that the
    ``further`` items from index ``first`` on add: exactly those rows of
    :func:`gate_tables`, without the engine runs no further item needs.

    The settings' gate-rate draws share one stream (purpose 5) with their scans, so the
    settings are replayed in order up to the last one a further item records at (its
    calibrated ``xi0`` and scan labels); the later settings and the campaign's own time
    scans are skipped.  Returns the four frames and the replayed rows of the settings
    (``{"pop", "par", "rates"}``: the first rows of the campaign's tables).
    """
    rng = rng_for(cfg, 5)
    settings, spectra, eta_Omega0, refs = _gate_setup(cfg, aom, lut)
    gates = [(float(it[1]), int(it[2])) for it in cfg.further if it[0] in ("scan", "time_scan")]
    last = max((settings.index(s) for s in gates if s in settings), default=-1)
    out = {"pop": [], "par": [], "rates": [], "time": [], "truth": []}
    with progress("gate experiments", (last + 1) * len(cfg.scan_shots)) as p:
        for (A, d) in settings[:last + 1]:
            _setting_scans(cfg, rng, eta_Omega0, A, d, *spectra[(A, d)], out, p, refs)
    replayed = {k: pd.DataFrame(out[k]) for k in ("pop", "par", "rates")}
    start = _further_gates(cfg, aom, lut, eta_Omega0, out, refs, first)
    return (*_frames(out, start), replayed)
