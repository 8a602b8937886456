"""Calibration recordings of a campaign: amplitude and phase runs of a drifting AOM, the DPD table.

The AOM's ``A_corr`` drifts from run to run (Ornstein-Uhlenbeck over days,
Supplement S2), its ``phi(1)`` within the gate day (over hours).  The gate
day's truth is the last amplitude run's drift value with the last phase
run's; the predistortion table is fitted to the gate day's run, to an older
one (``CampaignConfig.stale_days``) or to an unrecorded run of the AOM before it
drifted (``CampaignConfig.table_drift``).  Runs of ``further`` (a further amplitude or
phase run, :attr:`CampaignConfig.further`) come after the campaign's own runs,
drifting on from the last, each from its own stream: the campaign's runs, the
table and the gate day are drawn as without them.
"""

from __future__ import annotations

import datetime as _dt

import numpy as np
import pandas as pd

from dpdfit.fits.calibration import fit_amplitude
from dpdfit.models.transfer import TransferFunction
from dpdfit.simulation.aom_truth import (BraggAOM, ou_series, simulate_amplitude_run,
                                        simulate_phase_run)

from .config import CampaignConfig, rng_for

__all__ = ["calibration_runs", "table_index"]


def _iso(t0: _dt.datetime, days: float) -> str:
    return (t0 + _dt.timedelta(days=float(days))).isoformat(timespec="seconds")


def _detector(cfg: CampaignConfig, df: pd.DataFrame) -> None:
    """Photodiode response (the injected effects' ``inject_photodiode``), in place."""
    for e, v in cfg.injections():
        df["power"] = e.inject_photodiode(v, df["power"].to_numpy(), cfg.photodiode.p_full)


def _aom_drift(cfg: CampaignConfig, days_after_table, days_after_recording) -> np.ndarray:
    """Relative change of A_corr by the injected effects (``Injection.inject_aom``)."""
    d = np.zeros(np.shape(days_after_table))
    for e, v in cfg.injections():
        d = d + e.inject_aom(v, days_after_table, days_after_recording)
    return d


def _rf_gain(cfg: CampaignConfig, days_after_table, days_after_recording) -> np.ndarray:
    """The RF gain ahead of the AOM (1: the amplifier ``A_corr`` describes), moved by the
    injected effects (``Injection.inject_rf_gain``)."""
    g = np.ones(np.shape(days_after_table))
    for e, v in cfg.injections():
        g = g + e.inject_rf_gain(v, days_after_table, days_after_recording)
    return g


def _table_change(cfg: CampaignConfig) -> float:
    """Relative change of A_corr of the calibration behind the table: the simulator's own
    ``table_drift`` and the injected effects' (``Injection.inject_table``)."""
    changes = [e.inject_table(v) for e, v in cfg.injections()]
    if not any(changes):
        return cfg.table_drift
    return float(np.prod([1.0 + cfg.table_drift] + [1.0 + c for c in changes])) - 1.0


def _aom(cfg: CampaignConfig, A_corr: float, phi_1: float, rf_gain: float = 1.0) -> BraggAOM:
    """The AOM of one run or of the recordings (``rf_gain`` 1: no RF gain drift, the
    AOM every campaign had before it could drift)."""
    return BraggAOM(A_corr=A_corr, phi_1=phi_1, eta_ref=cfg.eta_ref, rf_gain=rf_gain)


def table_index(cfg) -> int:
    """Index of the gate day's amplitude run (the table's, unless stale): the last one
    before the recordings."""
    return cfg.n_amp_runs - 1 - cfg.runs_after_recordings


def _amplitude_runs(cfg, rng, t0, grid):
    """Days, drifting ``A_corr`` and recordings of the amplitude runs."""
    inner = np.sort(rng.uniform(0, cfg.amp_span_days, cfg.n_amp_runs - 2))
    days = np.concatenate([[0.0], inner, [cfg.amp_span_days]])
    days = np.sort(days + rng.uniform(0, 2 / 24, days.size))  # session start jitter
    A_corr = raw = cfg.A_corr_mean + ou_series(days, cfg.A_corr_sigma, cfg.A_corr_tau_days,
                                               rng)
    gain = np.ones(days.size)
    if cfg.injected:
        k = table_index(cfg)
        rec = days[k] + cfg.recording_hours[0] / 24
        A_corr = A_corr * (1 + _aom_drift(cfg, days - days[k], days - rec))
        gain = _rf_gain(cfg, days - days[k], days - rec)
    rows, truth = [], []
    for k, (d, ac, gk) in enumerate(zip(days, A_corr, gain)):
        aom = _aom(cfg, float(ac), cfg.phi1_mean, float(gk))
        df = simulate_amplitude_run(aom, grid, rng_for(cfg, 2, k), cfg.photodiode)
        _detector(cfg, df)
        df.insert(0, "timestamp", _iso(t0, d))
        df.insert(0, "run", f"R{k + 1:03d}")
        rows.append(df)
        truth.append({"run": f"R{k + 1:03d}", "day": float(d), "A_corr": float(ac),
                      **({"rf_gain": float(gk)} if gk != 1.0 else {})})
    _further_amplitude_runs(cfg, t0, grid, days, float(raw[-1]), rows, truth)
    return days, A_corr, rows, truth


def _ou_step(x: float, dt: float, sigma: float, tau: float, rng) -> float:
    """The drift ``dt`` after a value ``x`` (the step of :func:`ou_series`)."""
    a = np.exp(-dt / tau)
    return a * x + sigma * np.sqrt(1 - a * a) * rng.standard_normal()


def _further_amplitude_runs(cfg, t0, grid, days, raw_last, rows, truth) -> None:
    """The ``further`` amplitude runs, appended to ``rows`` and ``truth``.

    Each is taken "now": one to two hours after the previous run (or after the
    recordings, if no run followed them), its ``A_corr`` drifting on from the last
    run's, moved by the injected effects like any run; ``days`` and the runs before
    stay as they are (the table's run, the gate day).
    """
    k_day = table_index(cfg)
    rec = days[k_day] + cfg.recording_hours[0] / 24
    last = float(days[-1])
    d = max(last, float(days[k_day]) + cfg.recording_hours[-1] / 24)
    x, k = raw_last - cfg.A_corr_mean, cfg.n_amp_runs
    for j, item in enumerate(cfg.further):
        if item[0] != "amplitude_run":
            continue
        rng = rng_for(cfg, 8, j)
        d += (1 + rng.uniform(0, 1)) / 24
        x, last = _ou_step(x, d - last, cfg.A_corr_sigma, cfg.A_corr_tau_days, rng), d
        when = (np.array([d - days[k_day]]), np.array([d - rec]))
        ac = (cfg.A_corr_mean + x) * (1 + float(_aom_drift(cfg, *when)[0]))
        gk = float(_rf_gain(cfg, *when)[0])
        aom = _aom(cfg, float(ac), cfg.phi1_mean, gk)
        df = simulate_amplitude_run(aom, grid, rng, cfg.photodiode)
        _detector(cfg, df)
        df.insert(0, "timestamp", _iso(t0, d))
        df.insert(0, "run", f"R{k + 1:03d}")
        rows.append(df)
        truth.append({"run": f"R{k + 1:03d}", "day": d, "A_corr": float(ac), "further": True,
                      **({"rf_gain": gk} if gk != 1.0 else {})})
        k += 1


def _phase_runs(cfg, rng, t0, grid, gate_day, A_corr_day, gain_day=1.0):
    """Drifting ``phi(1)`` and recordings of the phase runs of the gate day."""
    hours = np.linspace(0.5, 0.5 + cfg.phase_span_hours, cfg.n_phase_runs)
    phi1 = cfg.phi1_mean + ou_series(hours, cfg.phi1_sigma, cfg.phi1_tau_hours, rng)
    rows, truth = [], []
    for k, (h, p1) in enumerate(zip(hours, phi1)):
        aom = _aom(cfg, A_corr_day, float(p1), gain_day)
        df = simulate_phase_run(aom, grid, rng_for(cfg, 3, k), cfg.heterodyne_phase)
        df.insert(0, "timestamp", _iso(t0, gate_day + h / 24))
        df.insert(0, "run", f"P{k + 1:03d}")
        rows.append(df)
        truth.append({"run": f"P{k + 1:03d}", "hours_after_amplitude_run": float(h),
                      "phi_at_1": float(p1)})
    _further_phase_runs(cfg, t0, grid, gate_day, A_corr_day, hours, phi1, rows, truth,
                        gain_day)
    return phi1, rows, truth


def _further_phase_runs(cfg, t0, grid, gate_day, A_corr_day, hours, phi1, rows, truth,
                        gain_day=1.0):
    """The ``further`` phase runs, appended to ``rows`` and ``truth``: each one step of
    the phase-run schedule after the previous one or after the recordings (a further run
    is taken now, after the diagnosis), ``phi(1)`` drifting on from the last run, the
    AOM's own phase of the injected effects added
    (:meth:`~dpdfit.simulation.injections.base.Injection.inject_phase_run`).  The day's
    truth stays the last phase run of the campaign (the model's run)."""
    step = cfg.phase_span_hours / max(cfg.n_phase_runs - 1, 1) or 0.5
    last = float(hours[-1])
    h = max(last, float(cfg.recording_hours[-1]))
    x, k = float(phi1[-1]) - cfg.phi1_mean, cfg.n_phase_runs
    for j, item in enumerate(cfg.further):
        if item[0] != "phase_run":
            continue
        rng = rng_for(cfg, 8, j)
        h += step
        x, last = _ou_step(x, h - last, cfg.phi1_sigma, cfg.phi1_tau_hours, rng), h
        aom = _aom(cfg, A_corr_day, cfg.phi1_mean + x, gain_day)
        df = simulate_phase_run(aom, grid, rng, cfg.heterodyne_phase)
        extra = sum((e.inject_phase_run(v, grid) for e, v in cfg.injections()),
                    np.zeros(grid.size))
        if np.any(extra):
            df["phase_rad"] = np.angle(np.exp(1j * (df["phase_rad"].to_numpy() + extra)))
        df.insert(0, "timestamp", _iso(t0, gate_day + h / 24))
        df.insert(0, "run", f"P{k + 1:03d}")
        rows.append(df)
        truth.append({"run": f"P{k + 1:03d}", "hours_after_amplitude_run": h,
                      "phi_at_1": cfg.phi1_mean + x, "further": True})
        k += 1


def _table_run(cfg, days, A_corr, amp_rows, grid, gate_day):
    """Index and recording of the calibration run behind the predistortion table."""
    target_day = gate_day - cfg.stale_days
    lut_run = int(np.argmin(np.abs(days - target_day)))
    sub = amp_rows[lut_run]
    change = _table_change(cfg)
    if change:
        # the table was made from a calibration of the AOM before it drifted
        # by table_drift in A_corr (a run that is not among the recordings)
        aom_t = BraggAOM(A_corr=float(A_corr[lut_run]) * (1 + change),
                         phi_1=cfg.phi1_mean, eta_ref=cfg.eta_ref)
        sub = simulate_amplitude_run(aom_t, grid, rng_for(cfg, 7), cfg.photodiode)
        _detector(cfg, sub)
    return lut_run, sub


def _reading_error_at_max(cfg: CampaignConfig) -> float:
    """Relative photodiode reading error (the injected effects' ``inject_photodiode``) at
    full scale, the day's largest true power: ``detector_nonlinearity``'s ``k_det``."""
    read = np.array([cfg.photodiode.p_full])
    for e, v in cfg.injections():
        read = e.inject_photodiode(v, read, cfg.photodiode.p_full)
    return float(read[0] / cfg.photodiode.p_full - 1)


def _y1_drift(cfg: CampaignConfig, day_aom: BraggAOM, A_corr_run: float) -> float:
    """Today's y(1) as a calibration run measures it over that of the gate day's run,
    minus 1 (``A_corr``'s own ratio unless the RF gain drifted)."""
    if day_aom.rf_gain == 1.0:
        return day_aom.A_corr / A_corr_run - 1
    return day_aom.measured_A_corr / _aom(cfg, A_corr_run, day_aom.phi_1).measured_A_corr - 1


def calibration_runs(cfg: CampaignConfig):
    """Amplitude and phase calibration runs with run-to-run drift.

    Returns ``(amplitude table, phase table, the gate day's AOM, the transfer
    function of the predistortion table, truth dict)``.
    """
    t0 = _dt.datetime.fromisoformat(cfg.start)
    rng = rng_for(cfg, 1)
    grid = np.round(np.linspace(0.0, 1.0, cfg.cal_points), 10)
    days, A_corr, amp_rows, amp_truth = _amplitude_runs(cfg, rng, t0, grid)
    k_day = table_index(cfg)
    gate_day = days[k_day]
    # the AOM at the recordings: the gate day's run's, moved by what is injected
    at_rec = (np.array([cfg.recording_hours[0] / 24]), np.zeros(1))
    A_rec = float(A_corr[k_day]) * (1 + float(_aom_drift(cfg, *at_rec)[0]))
    gain_rec = float(_rf_gain(cfg, *at_rec)[0])
    phi1, ph_rows, ph_truth = _phase_runs(cfg, rng, t0, grid, gate_day, A_rec, gain_rec)
    amp = pd.concat(amp_rows, ignore_index=True)
    ph = pd.concat(ph_rows, ignore_index=True)
    # the day's truth: drift value of the gate day's amplitude run, last phase run
    day_aom = _aom(cfg, A_rec, float(phi1[-1]), gain_rec)
    # predistortion table: from the run of the gate day, or a stale one
    lut_run, sub = _table_run(cfg, days, A_corr, amp_rows, grid, gate_day)
    fit = fit_amplitude(sub["A"], sub["power"], sub["power_err"], cfg.order)
    day_run = amp_rows[k_day]
    day_fit = fit_amplitude(day_run["A"], day_run["power"], day_run["power_err"], cfg.order)
    tf = TransferFunction(fit.powers, fit.coefficients)
    truth = {"amplitude_runs": amp_truth, "phase_runs": ph_truth, "gate_day": float(gate_day),
             "lut_run": f"R{lut_run + 1:03d}", "lut_fit_A_corr": fit.A_corr,
             "day_fit_A_corr": day_fit.A_corr,
             "lut_relative_A_corr": fit.A_corr / day_fit.A_corr - 1,
             "lut_relative_y05": float(fit.y(0.5) / day_fit.y(0.5) - 1),
             "detector_nonlinearity_rel_max": _reading_error_at_max(cfg),
             "recording_y1_drift": _y1_drift(cfg, day_aom, float(A_corr[k_day])),
             "day_A_corr": A_rec, "day_phi_at_1": float(phi1[-1])}
    return amp, ph, day_aom, tf, truth
