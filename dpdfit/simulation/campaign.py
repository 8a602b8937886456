"""Simulator of a complete, realistic measurement campaign (synthetic recordings).

The truth is physical, never the fit polynomials: a tanh-compressed RF
amplifier driving a Bragg-regime AOM with amplitude-to-phase conversion and
optional memory (:mod:`dpdfit.simulation.aom_truth`), drifting from run to run; gate
experiments come from the exact two-ion spin-motion dynamics driven by the
optical spectrum that this AOM produces (:mod:`dpdfit.models.gate_sim`).  The
simulator writes the campaign layout that labs can also write their own
recordings in (see ``CAMPAIGN_FILES`` and the generated README.md):

``campaign.json``, ``calibration_amplitude.csv``, ``calibration_phase.csv``,
``spectra.csv``, ``traces.csv`` + ``traces/``, ``populations.csv``,
``parity.csv``, ``gate_rates.csv``, ``time_scans.csv``, ``README.md`` and
``truth.json`` (generating parameters; no analysis reads it).

Everything is derived from one seed through :class:`numpy.random.SeedSequence`
children keyed by purpose (and by amplitude/flag for traces), so the campaign
is regenerated bit for bit, and any single trace can be regenerated from the
seed recorded in ``traces.csv``.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import hashlib
import io
import json
import os
import shutil
import tempfile
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from dpdfit.core.version import __version__
from dpdfit.simulation.aom_truth import (BraggAOM, HeterodyneNoise, PhotodiodeNoise, ou_series,
                        simulate_amplitude_run, simulate_phase_run)
from dpdfit.fits.calibration import fit_amplitude
from dpdfit.errors import InputError
from dpdfit.fits.heterodyne import trace_tone_powers
from dpdfit.models.transfer import TransferFunction, predistortion_table
from dpdfit.models.waveforms import cardioid, sample_grid, synthesize

__all__ = ["CampaignConfig", "simulate_campaign", "parse_effects", "EFFECTS",
           "drive_envelope", "direct_tones", "tone_readout", "generate_trace",
           "regenerate_trace", "campaign_hashes", "CAMPAIGN_FILES"]

CAMPAIGN_FILES = ("campaign.json", "calibration_amplitude.csv", "calibration_phase.csv",
                  "spectra.csv", "traces.csv", "populations.csv", "parity.csv",
                  "gate_rates.csv", "time_scans.csv", "README.md", "truth.json")

#: Effects that can be concealed in a simulated campaign: name -> (unit, meaning).
EFFECTS = {
    "aom_memory": ("ns", "single-pole memory of the modulator, time constant (Wiener model)"),
    "aom_memory_offset": ("MHz", "offset of the AOM response centre from the carrier "
                                 "(red/blue asymmetry of the memory)"),
    "stale_calibration": ("days", "the predistortion table comes from the calibration run "
                                  "this many days before the gate day"),
    "motional_heating": ("quanta/ms", "heating rate of the stretch mode"),
    "dephasing": ("1/s", "extra qubit dephasing rate added to 1/T2"),
    "spam_offset": ("probability", "extra state-preparation error per ion"),
    "gate_rate_miscalibration": ("dB", "systematic optical-power offset between the xi0 "
                                       "calibration and the gate"),
    "detector_nonlinearity": ("1/full scale", "quadratic photodiode response "
                                              "P_meas = P (1 + k P/P_full) in calibrations"),
    "higher_nbar": ("quanta", "extra initial mean phonon number"),
    "am_pm_omitted": ("rad", "AM-to-PM conversion in the beam path after the calibrated AOM "
                             "(phase at full drive, ~|y|^2), not seen by the phase calibration"),
    "higher_order_im": ("1", "fifth-order field distortion after the calibrated AOM: relative "
                             "field change at full drive (~|y|^4)"),
    "calibration_drift": ("fraction", "A_corr of the calibration behind the predistortion table "
                                      "relative to the gate day (the AOM drifted since)"),
}


def parse_effects(spec: str | None) -> dict:
    """``"aom_memory=50,spam_offset=0.002"`` -> ``{"aom_memory": 50.0, ...}``."""
    out: dict = {}
    if not spec:
        return out
    for item in spec.split(","):
        name, sep, val = item.partition("=")
        name = name.strip()
        if name not in EFFECTS:
            raise InputError(f"unknown effect '{name}'; known: {', '.join(EFFECTS)}")
        try:
            if not sep:
                raise ValueError
            out[name] = float(val)
        except ValueError:
            raise InputError(f"effect '{item.strip()}' must be NAME=STRENGTH "
                             f"(strength in {EFFECTS[name][0]})") from None
        if not np.isfinite(out[name]):
            raise InputError(f"effect '{name}': strength must be finite")
    return out


@dataclass(frozen=True)
class CampaignConfig:
    """All generating parameters of a campaign (written to ``truth.json``).

    Units: amplitudes normalised, frequencies Hz, times s unless the name says
    otherwise (``_days``, ``_hours``, ``_us``, ``_khz``).
    """

    seed: int = 20260329
    start: str = "2025-08-04T08:30:00+00:00"
    # AOM truth and drift (Supplement S2)
    A_corr_mean: float = 0.5655
    A_corr_sigma: float = 0.0091
    A_corr_tau_days: float = 3.0
    phi1_mean: float = 0.2776
    phi1_sigma: float = 0.0009
    phi1_tau_hours: float = 1.0
    eta_ref: float = 0.80
    memory_tau: float = 0.0
    memory_offset_hz: float = 0.0
    # calibration recordings
    n_amp_runs: int = 34
    amp_span_days: float = 110.0
    n_phase_runs: int = 6
    phase_span_hours: float = 3.0
    cal_points: int = 201
    photodiode: PhotodiodeNoise = field(default_factory=PhotodiodeNoise)
    heterodyne_phase: HeterodyneNoise = field(default_factory=HeterodyneNoise)
    detector_nonlinearity: float = 0.0
    # predistortion
    lut_points: int = 4096
    order: int = 8
    stale_days: float = 0.0
    table_drift: float = 0.0
    # beam path after the calibrated AOM (concealed effects; 0 = none)
    post_pm_rad: float = 0.0
    post_k5: float = 0.0
    # heterodyne spectra (Supplement S4)
    fs: float = 1e9
    n_samples: int = 2 ** 21
    f_det: float = 20e6
    nu: float = 1.84e6
    xi0_spec: float = 20e3
    trace_amplitudes: tuple = tuple(np.round(np.linspace(0.05, 1.0, 39), 4))
    trace_noise_rms: float = 0.015
    power_jitter_db: float = 0.2
    bundled_traces: tuple = ((0.5, 0), (0.5, 1))
    spectra_harmonics: tuple = (-1, 0, 1, 2, 3, 4)
    #: "traces": synthesise every heterodyne trace and extract its tones (S4);
    #: "direct": exact tone amplitudes of the field plus the complex noise that
    #: the flat-top extraction of such a trace would add (fast; harness campaigns)
    spectra_mode: str = "traces"
    # gate experiments (Supplement S7, main text)
    gate_amplitudes: tuple = (0.4, 0.5, 0.6, 0.7, 0.8)
    eta_ld: float = 0.026
    nbar: float = 0.1
    alpha_khz: float = 3.42
    xi0_rel_err: float = 0.01
    T2: float = 50e-3
    extra_dephasing: float = 0.0
    ndot: float = 5.0
    p_prep: float = 0.003
    p_det: float = 5e-5
    gate_power_offset_db: float = 0.0
    scan_shots: tuple = ((625, 625), (625, 625), (500, 625), (625, 400))
    time_scan_A: float = 0.5
    time_scan_points: int = 25
    time_scan_max: float = 1.5
    harmonics_gate: tuple = tuple(range(-2, 6))
    effects: dict = field(default_factory=dict)

    def with_effects(self, effects: dict) -> "CampaignConfig":
        """Config with the named effects applied (see :data:`EFFECTS`)."""
        kw = {}
        for name, s in effects.items():
            if name == "aom_memory":
                kw["memory_tau"] = s * 1e-9
            elif name == "aom_memory_offset":
                kw["memory_offset_hz"] = s * 1e6
            elif name == "stale_calibration":
                kw["stale_days"] = s
            elif name == "motional_heating":
                kw["ndot"] = s * 1e3
            elif name == "dephasing":
                kw["extra_dephasing"] = s
            elif name == "spam_offset":
                kw["p_prep"] = self.p_prep + s
            elif name == "gate_rate_miscalibration":
                kw["gate_power_offset_db"] = s
            elif name == "detector_nonlinearity":
                kw["detector_nonlinearity"] = s
            elif name == "higher_nbar":
                kw["nbar"] = self.nbar + s
            elif name == "am_pm_omitted":
                kw["post_pm_rad"] = s
            elif name == "higher_order_im":
                kw["post_k5"] = s
            elif name == "calibration_drift":
                kw["table_drift"] = s
        return dataclasses.replace(self, effects=dict(effects), **kw)


# --------------------------------------------------------------------------- helpers


def _rng(cfg: CampaignConfig, *key: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence([cfg.seed, *key]))


def _iso(t0: _dt.datetime, days: float) -> str:
    return (t0 + _dt.timedelta(days=float(days))).isoformat(timespec="seconds")


def _csv(df: pd.DataFrame) -> str:
    return df.to_csv(index=False, float_format="%.10g", lineterminator="\n")


def _npz_bytes(arrays: dict) -> bytes:
    """Deterministic .npz (fixed zip timestamps, deflate)."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
        for name, arr in arrays.items():
            b = io.BytesIO()
            np.save(b, arr, allow_pickle=False)
            zf.writestr(zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0)),
                        b.getvalue(), compress_type=zipfile.ZIP_DEFLATED)
    return buf.getvalue()


# --------------------------------------------------------------------------- calibrations


def _calibrations(cfg: CampaignConfig):
    """Amplitude and phase calibration runs with run-to-run drift."""
    t0 = _dt.datetime.fromisoformat(cfg.start)
    rng = _rng(cfg, 1)
    inner = np.sort(rng.uniform(0, cfg.amp_span_days, cfg.n_amp_runs - 2))
    days = np.concatenate([[0.0], inner, [cfg.amp_span_days]])
    days = np.sort(days + rng.uniform(0, 2 / 24, days.size))  # session start jitter
    A_corr = cfg.A_corr_mean + ou_series(days, cfg.A_corr_sigma, cfg.A_corr_tau_days, rng)
    grid = np.round(np.linspace(0.0, 1.0, cfg.cal_points), 10)
    amp_rows, amp_truth = [], []
    for k, (d, ac) in enumerate(zip(days, A_corr)):
        aom = BraggAOM(A_corr=float(ac), phi_1=cfg.phi1_mean, eta_ref=cfg.eta_ref)
        df = simulate_amplitude_run(aom, grid, _rng(cfg, 2, k), cfg.photodiode)
        if cfg.detector_nonlinearity:
            p = df["power"].to_numpy()
            df["power"] = p * (1 + cfg.detector_nonlinearity * p / cfg.photodiode.p_full)
        df.insert(0, "timestamp", _iso(t0, d))
        df.insert(0, "run", f"R{k + 1:03d}")
        amp_rows.append(df)
        amp_truth.append({"run": f"R{k + 1:03d}", "day": float(d), "A_corr": float(ac)})
    gate_day = days[-1]
    hours = np.linspace(0.5, 0.5 + cfg.phase_span_hours, cfg.n_phase_runs)
    phi1 = cfg.phi1_mean + ou_series(hours, cfg.phi1_sigma, cfg.phi1_tau_hours, rng)
    ph_rows, ph_truth = [], []
    for k, (h, p1) in enumerate(zip(hours, phi1)):
        aom = BraggAOM(A_corr=float(A_corr[-1]), phi_1=float(p1), eta_ref=cfg.eta_ref)
        df = simulate_phase_run(aom, grid, _rng(cfg, 3, k), cfg.heterodyne_phase)
        df.insert(0, "timestamp", _iso(t0, gate_day + h / 24))
        df.insert(0, "run", f"P{k + 1:03d}")
        ph_rows.append(df)
        ph_truth.append({"run": f"P{k + 1:03d}", "hours_after_amplitude_run": float(h),
                         "phi_at_1": float(p1)})
    amp = pd.concat(amp_rows, ignore_index=True)
    ph = pd.concat(ph_rows, ignore_index=True)
    # the day's truth: drift value of the last amplitude run, last phase run
    day_aom = BraggAOM(A_corr=float(A_corr[-1]), phi_1=float(phi1[-1]), eta_ref=cfg.eta_ref,
                       memory_tau=cfg.memory_tau, memory_offset_hz=cfg.memory_offset_hz)
    # predistortion table: from the run of the gate day, or a stale one
    target_day = gate_day - cfg.stale_days
    lut_run = int(np.argmin(np.abs(days - target_day)))
    sub = amp_rows[lut_run]
    if cfg.table_drift:
        # the table was made from a calibration of the AOM before it drifted
        # by table_drift in A_corr (a run that is not among the recordings)
        aom_t = BraggAOM(A_corr=float(A_corr[lut_run]) * (1 + cfg.table_drift),
                         phi_1=cfg.phi1_mean, eta_ref=cfg.eta_ref)
        sub = simulate_amplitude_run(aom_t, grid, _rng(cfg, 7), cfg.photodiode)
        if cfg.detector_nonlinearity:
            p = sub["power"].to_numpy()
            sub["power"] = p * (1 + cfg.detector_nonlinearity * p / cfg.photodiode.p_full)
    fit = fit_amplitude(sub["A"], sub["power"], sub["power_err"], cfg.order)
    day_fit = fit_amplitude(amp_rows[-1]["A"], amp_rows[-1]["power"],
                            amp_rows[-1]["power_err"], cfg.order)
    tf = TransferFunction(fit.powers, fit.coefficients)
    truth = {"amplitude_runs": amp_truth, "phase_runs": ph_truth, "gate_day": float(gate_day),
             "lut_run": f"R{lut_run + 1:03d}", "lut_fit_A_corr": fit.A_corr,
             "day_fit_A_corr": day_fit.A_corr,
             "lut_relative_A_corr": fit.A_corr / day_fit.A_corr - 1,
             "lut_relative_y05": float(fit.y(0.5) / day_fit.y(0.5) - 1),
             "detector_nonlinearity_rel_max": cfg.detector_nonlinearity
             * float(amp_rows[-1]["power"].max()) / cfg.photodiode.p_full,
             "day_A_corr": float(A_corr[-1]), "day_phi_at_1": float(phi1[-1])}
    return amp, ph, day_aom, tf, truth


# --------------------------------------------------------------------------- traces


def _beam_path(cfg: CampaignConfig, aom: BraggAOM, y: np.ndarray) -> np.ndarray:
    """Distortion after the calibrated AOM (concealed effects ``am_pm_omitted``,
    ``higher_order_im``): ``y (1 + k5 r^4) exp(i phi r^2)``, ``r = |y| / y(1)``."""
    if not (cfg.post_pm_rad or cfg.post_k5):
        return y
    r2 = (np.abs(y) / aom.true_A_corr) ** 2
    return y * (1 + cfg.post_k5 * r2 ** 2) * np.exp(1j * cfg.post_pm_rad * r2)


def _dpd_lut(tf: TransferFunction, points: int):
    target, rf, _ = predistortion_table(tf, points)
    return target, rf


def _trace_field(cfg: CampaignConfig, aom: BraggAOM, lut, A: float, dpd: int) -> np.ndarray:
    """One gate period (``fs / xi0_spec`` samples) of the optical field envelope."""
    return _beam_path(cfg, aom, aom.field_periodic(drive_envelope(cfg, A, lut, dpd), cfg.fs))


def drive_envelope(cfg: CampaignConfig, A: float, lut, dpd: int) -> np.ndarray:
    """One gate period of the real RF envelope: Cardioid(1,2), peak ``A``, DPD by the table."""
    tones = cardioid()
    per = int(round(cfg.fs / cfg.xi0_spec))                   # samples per gate period
    t = np.arange(per) / cfg.fs
    fb, fr = tones.frequencies(cfg.nu, cfg.xi0_spec)
    env = np.zeros(per)
    for f_b, f_r, r in zip(fb, fr, tones.r_blue):
        env += r * (np.cos(2 * np.pi * f_b * t) + np.cos(2 * np.pi * f_r * t))
    # at 1 GS/s (~500 samples per cycle) the sampled peak is the continuous one
    env *= A / np.max(np.abs(env))
    if dpd:
        target, rf_tab = lut
        env = np.sign(env) * np.interp(np.abs(env), target, rf_tab)
    return env


def generate_trace(cfg: CampaignConfig, aom: BraggAOM, lut, A: float, dpd: int,
                   seed_key: tuple) -> tuple[np.ndarray, float]:
    """One heterodyne photodiode trace (float64, volts) and its power factor.

    The Cardioid(1,2) envelope (one 50 us period at ``fs``, tiled) is
    predistorted through the day's lookup table by linear interpolation (as
    an AWG table would), passed through the physical AOM, beaten against the
    reference at ``f_det`` (``Re[y e^{i 2 pi f_det t}]``, 1 V per unit field),
    scaled by the laser-power jitter and given white detector noise.
    """
    rng = _rng(cfg, *seed_key)
    y = _trace_field(cfg, aom, lut, A, dpd)
    per = y.size
    reps = -(-cfg.n_samples // per)
    y = np.tile(y, reps)[:cfg.n_samples]
    n = np.arange(cfg.n_samples)
    power = 10 ** (cfg.power_jitter_db * rng.standard_normal() / 20)
    phase0 = rng.uniform(0, 2 * np.pi)
    carrier = np.exp(1j * (2 * np.pi * (cfg.f_det / cfg.fs) * n + phase0))
    trace = power * (y * carrier).real + cfg.trace_noise_rms * rng.standard_normal(cfg.n_samples)
    return trace, power


def _flattop_enbw() -> float:
    """Equivalent noise bandwidth (bins) of the flat-top window of the extraction."""
    from scipy.signal import get_window
    w = get_window("flattop", 1 << 16, fftbins=True)
    return float(w.size * np.sum(w ** 2) / np.sum(w) ** 2)


def direct_tones(cfg: CampaignConfig, aom: BraggAOM, lut, A: float, dpd: int,
                 seed_key: tuple) -> dict:
    """Tone powers as the extraction of a trace would report them, without the trace.

    The exact Fourier amplitudes ``c`` of the field's tones, times the
    trace's laser-power factor, plus the complex noise that white detector
    noise of rms ``sigma`` leaves in a flat-top amplitude estimate from
    ``N`` samples: ``E|n|^2 = 4 sigma^2 ENBW / N``.  The reported floor is
    the median of that noise power (``ln 2`` times its mean), as in
    :func:`dpdfit.fits.heterodyne.trace_tone_powers`; validity follows its SNR
    rules (20 dB for gate tones, 10 dB for IM tones).
    """
    return tone_readout(cfg, _trace_field(cfg, aom, lut, A, dpd), _rng(cfg, *seed_key))


def tone_readout(cfg: CampaignConfig, y: np.ndarray, rng: np.random.Generator) -> dict:
    """Tone powers of one period ``y`` of a field as the extraction would report them.

    See :func:`direct_tones`; returns ``{"red"|"blue": (P_dB, valid, snr_db)}``
    over ``cfg.spectra_harmonics``.
    """
    power = 10 ** (cfg.power_jitter_db * rng.standard_normal() / 20)
    spec = np.fft.fft(y) / y.size
    n = np.asarray(cfg.spectra_harmonics)
    k = np.rint((cfg.nu + n * cfg.xi0_spec) / cfg.xi0_spec).astype(int)
    N0 = 4 * cfg.trace_noise_rms ** 2 * _flattop_enbw() / cfg.n_samples
    floor_db = 10 * np.log10(N0 * np.log(2))
    out = {}
    for sb, kk in (("blue", k), ("red", -k)):
        noise = np.sqrt(N0 / 2) * (rng.standard_normal(n.size) + 1j * rng.standard_normal(n.size))
        P = 20 * np.log10(np.abs(power * spec[kk % y.size] + noise))
        snr = P - floor_db
        valid = np.where(np.isin(n, (1, 2)), snr >= 20.0, snr >= 10.0)
        out[sb] = (P, valid, snr)
    return out


def regenerate_trace(seed: str, effects: dict | None = None,
                     config: CampaignConfig | None = None) -> tuple[np.ndarray, float]:
    """Regenerate one trace of a campaign from its ``traces.csv`` seed string.

    ``seed`` is ``"<campaign seed>:4:<amplitude index>:<dpd>"``; ``effects``
    must be those the campaign was simulated with.  Returns the int16 samples
    and the scale exactly as a bundled ``.npz`` holds them (volts = q * scale).
    """
    try:
        camp_seed, purpose, i, d = (int(v) for v in str(seed).split(":"))
        if purpose != 4:
            raise ValueError
    except ValueError:
        raise InputError(f"trace seed '{seed}' is not '<seed>:4:<index>:<dpd>'") from None
    cfg = dataclasses.replace(config or CampaignConfig(), seed=camp_seed)
    cfg = cfg.with_effects(effects or {})
    if not 0 <= i < len(cfg.trace_amplitudes) or d not in (0, 1):
        raise InputError(f"trace seed '{seed}': amplitude index or dpd out of range")
    _, _, aom, tf, _ = _calibrations(cfg)
    x, _ = generate_trace(cfg, aom, _dpd_lut(tf, cfg.lut_points), float(cfg.trace_amplitudes[i]),
                          d, (4, i, d))
    return _int16(x)


def _int16(trace: np.ndarray) -> tuple[np.ndarray, float]:
    scale = float(np.max(np.abs(trace))) / 32000.0
    return np.round(trace / scale).astype(np.int16), scale


def _spectra(cfg, aom, lut, progress):
    """All traces of the grid: extracted tone powers, bundled raw traces."""
    rows, index, bundled = [], [], {}
    items = [(i, A, d) for i, A in enumerate(cfg.trace_amplitudes) for d in (0, 1)]
    with progress("heterodyne traces", len(items)) as p:
        for i, A, d in items:
            key = (4, i, d)
            if cfg.spectra_mode == "direct":
                tones = direct_tones(cfg, aom, lut, float(A), d, key)
                for sb in ("red", "blue"):
                    P, valid, snr = tones[sb]
                    for j, nn in enumerate(cfg.spectra_harmonics):
                        rows.append({"A": float(A), "dpd": d, "sideband": sb, "n": int(nn),
                                     "P_dB": float(P[j]), "valid": int(valid[j]),
                                     "snr_db": float(snr[j])})
                p.update()
                continue
            x, power = generate_trace(cfg, aom, lut, float(A), d, key)
            q, scale = _int16(x)
            res = trace_tone_powers(q * scale, cfg.fs, cfg.f_det, cfg.nu, cfg.xi0_spec,
                                    harmonics=cfg.spectra_harmonics)
            for sb in ("red", "blue"):
                t = getattr(res, sb)
                for n in res.harmonics:
                    rows.append({"A": float(A), "dpd": d, "sideband": sb, "n": int(n),
                                 "P_dB": t.P_dB[n], "valid": int(bool(t.valid[n])),
                                 "snr_db": t.snr_db[n]})
            seed_str = f"{cfg.seed}:4:{i}:{d}"
            if any(abs(A - a) < 1e-9 and d == dd for a, dd in cfg.bundled_traces):
                fname = f"traces/trace_A{A:.3f}_dpd{d}.npz"
                bundled[fname] = _npz_bytes({"trace": q, "scale": np.array(scale)})
                index.append({"file": fname, "A": float(A), "dpd": d, "fs": cfg.fs,
                              "fdet": cfg.f_det, "nu": cfg.nu, "xi0": cfg.xi0_spec,
                              "n_samples": cfg.n_samples, "seed": seed_str})
            p.update()
    return pd.DataFrame(rows), pd.DataFrame(index), bundled


# --------------------------------------------------------------------------- gates


def _gate_spectrum(cfg, aom, lut, A, dpd):
    """Complex tone amplitudes (blue, red) of the optical field for the gate waveform."""
    tones = cardioid()
    grid = sample_grid(cfg.nu, cfg.xi0_spec, tones)
    w = synthesize(tones, grid, A)
    if dpd:
        target, rf_tab = lut
        w = np.sign(w) * np.interp(np.abs(w), target, rf_tab)
    y = _beam_path(cfg, aom, aom.field_periodic(w, grid.fs))
    spec = np.fft.fft(y) / grid.n_samples
    n = np.asarray(cfg.harmonics_gate)
    kb, kr = grid.tone_bins(n)
    from dpdfit.models.gate_sim import field_amplitudes
    b, c = field_amplitudes(spec[kb], spec[kr])        # engine's positive-frequency convention
    return n, b, c


def _gates(cfg, aom, lut, progress):
    from dpdfit.models import gate_sim
    rng = _rng(cfg, 5)
    settings = [(A, d) for A in cfg.gate_amplitudes for d in (0, 1)]
    spectra = {s: _gate_spectrum(cfg, aom, lut, *s) for s in settings}
    # eta*Omega0 such that the anchor (A=0.4, no DPD) calibrates to alpha
    n0, b0, c0 = _gate_spectrum(cfg, aom, lut, 0.4, 0)
    xi_unit = gate_sim.calibrate_xi0(b0, c0, n0, 1.0)
    eta_Omega0 = cfg.alpha_khz * 1e3 / xi_unit
    pop_rows, par_rows, rate_rows, ts_rows, truth = [], [], [], [], []
    phases = np.arange(16) * 2 * np.pi / 16
    with progress("gate experiments", len(settings) * len(cfg.scan_shots) + 2) as p:
        for (A, d) in settings:
            n, b, c = spectra[(A, d)]
            xi_true = gate_sim.calibrate_xi0(b, c, n, eta_Omega0)
            xi_cal = xi_true * (1 + cfg.xi0_rel_err * rng.standard_normal())
            rate_rows.append({"A": A, "dpd": d, "xi0_khz": xi_cal / 1e3,
                              "xi0_err_khz": cfg.xi0_rel_err * xi_cal / 1e3})
            fids = []
            fids_gate, fids_app = [], []
            for s, (shots_pop, shots_par) in enumerate(cfg.scan_shots):
                eps_db = cfg.gate_power_offset_db + cfg.power_jitter_db * rng.standard_normal()
                res = gate_sim.simulate_setting(
                    b, c, n, eta_Omega0, xi_cal, nbar=cfg.nbar, T2=_t2(cfg), ndot=cfg.ndot,
                    p_prep=cfg.p_prep, p_det=cfg.p_det, parity_phases=phases,
                    power_error_db=eps_db)
                counts = res.sample(rng, shots_pop, shots_par)
                pop_rows.append({"A": A, "dpd": d, "scan": s + 1, "n00": counts["n00"],
                                 "n01_10": counts["n01_10"], "n11": counts["n11"],
                                 "n_even": counts["n00"] + counts["n11"], "shots": shots_pop})
                for ph, k in zip(phases, counts["parity_even"]):
                    par_rows.append({"A": A, "dpd": d, "scan": s + 1, "phase_rad": float(ph),
                                     "n_even": int(k), "shots": shots_par})
                fids.append(res.fidelity_max)
                fids_gate.append(res.fidelity_gate)
                fids_app.append(res.apparent_fidelity)
                p.update()
            truth.append({"A": A, "dpd": d, "xi0_true_hz": xi_true, "xi0_cal_hz": xi_cal,
                          "bell_fidelity_mean_over_scans": float(np.mean(fids)),
                          "gate_only_fidelity_mean_over_scans": float(np.mean(fids_gate)),
                          "apparent_fidelity_mean_over_scans": float(np.mean(fids_app))})
        for d in (0, 1):
            A = cfg.time_scan_A
            n, b, c = spectra[(A, d)]
            xi_cal = next(r["xi0_khz"] for r in rate_rows if r["A"] == A and r["dpd"] == d) * 1e3
            t = np.linspace(0, cfg.time_scan_max / xi_cal, cfg.time_scan_points)
            res = gate_sim.simulate_setting(
                b, c, n, eta_Omega0, xi_cal, nbar=cfg.nbar, T2=_t2(cfg), ndot=cfg.ndot,
                p_prep=cfg.p_prep, p_det=cfg.p_det, parity_phases=phases, scan_times=t,
                # a time scan is a gate run: it carries the systematic power offset
                # (no per-scan jitter is drawn, which keeps older campaigns' bytes)
                power_error_db=cfg.gate_power_offset_db)
            counts = res.sample(rng, 0, 0, shots_scan=625)
            for ti, cnt in zip(t, counts.scan_counts):
                ts_rows.append({"A": A, "dpd": d, "t_us": ti * 1e6, "n00": int(cnt[0]),
                                "n01_10": int(cnt[1]), "n11": int(cnt[2]), "shots": 625})
            p.update()
    return (pd.DataFrame(pop_rows), pd.DataFrame(par_rows), pd.DataFrame(rate_rows),
            pd.DataFrame(ts_rows), {"eta_Omega0": eta_Omega0, "settings": truth})


def _t2(cfg) -> float:
    rate = 1.0 / cfg.T2 + cfg.extra_dephasing
    return 1.0 / rate


# --------------------------------------------------------------------------- driver


def _readme(cfg: CampaignConfig, name: str) -> str:
    from dpdfit.simulation.campaign_readme import README_TEMPLATE
    return README_TEMPLATE.format(name=name, seed=cfg.seed,
                                  effects=(", ".join(f"{k}={v:g}" for k, v in cfg.effects.items())
                                           or "none"))


def simulate_campaign(outdir: str | os.PathLike, seed: int = 20260329, effects: dict | None = None,
                      *, config: CampaignConfig | None = None, progress=None,
                      include_gates: bool = True) -> dict:
    """Simulate a campaign and write it to ``outdir`` (which must not exist or be empty).

    Files are written into a temporary folder beside ``outdir`` and moved
    into place only when complete.  Returns the ``truth`` dict.
    """
    from dpdfit.core.progress import Progress
    if progress is None:
        def progress(label, total):
            return Progress(label, total)
    out = Path(outdir)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise InputError("output folder exists and is not empty; choose a new folder",
                         file=str(out))
    cfg = (config or CampaignConfig(seed=seed))
    cfg = dataclasses.replace(cfg, seed=seed) if config is None else cfg
    nominal = cfg
    cfg = cfg.with_effects(effects or {})
    amp, ph, aom, tf, cal_truth = _calibrations(cfg)
    lut = _dpd_lut(tf, cfg.lut_points)
    spectra, index, bundled = _spectra(cfg, aom, lut, progress)
    files = {
        "calibration_amplitude.csv": _csv(amp),
        "calibration_phase.csv": _csv(ph),
        "spectra.csv": _csv(spectra),
        "traces.csv": _csv(index),
    }
    gate_truth = None
    if include_gates:
        pop, par, rates, ts, gate_truth = _gates(cfg, aom, lut, progress)
        files.update({"populations.csv": _csv(pop), "parity.csv": _csv(par),
                      "gate_rates.csv": _csv(rates), "time_scans.csv": _csv(ts)})
    campaign = {
        "name": f"synthetic campaign, seed {cfg.seed}",
        "synthetic": True,
        "generator": f"dpdfit {__version__} simulate-campaign --seed {cfg.seed}",
        "nu_hz": cfg.nu, "xi0_spectra_hz": cfg.xi0_spec, "f_det_hz": cfg.f_det,
        "fs_traces_hz": cfg.fs, "eta_ld": cfg.eta_ld, "nbar_assumed": cfg.nbar,
        "eta_ref": cfg.eta_ref, "order": cfg.order,
        # what the lab's records say: the table was made from the gate day's run
        "predistortion_table": {"amplitude_run": f"R{cfg.n_amp_runs:03d}",
                                "points": cfg.lut_points,
                                "order": cfg.order, "interpolation": "linear"},
        "phase_run_for_model": f"P{cfg.n_phase_runs:03d}",
        "gate_waveform": "Cardioid(1,2)",
        "parity_phases": 16, "nominal_shots": 625,
        # the lab's error model (its own characterisation, Table S3), not the truth
        "error_model": {"nbar": nominal.nbar, "T2_s": nominal.T2,
                        "heating_quanta_per_s": nominal.ndot, "p_prep": nominal.p_prep,
                        "p_det": nominal.p_det, "power_jitter_db": nominal.power_jitter_db,
                        "xi0_rel_err": nominal.xi0_rel_err},
        "units": {"A": "normalised RF amplitude", "power": "photodiode V*us (arbitrary)",
                  "phase_rad": "rad", "P_dB": "dB re unit-amplitude sinusoid in trace volts",
                  "xi0_khz": "kHz", "t_us": "microseconds", "timestamp": "ISO 8601 UTC"},
    }
    truth = {"config": _jsonable_config(cfg), "calibration": cal_truth, "gates": gate_truth}
    files["campaign.json"] = json.dumps(campaign, indent=2, sort_keys=True) + "\n"
    # 10 significant digits: independent of BLAS threading in the last bits
    files["truth.json"] = json.dumps(_rounded(json.loads(json.dumps(truth, default=float))),
                                     indent=2, sort_keys=True) + "\n"
    files["README.md"] = _readme(cfg, f"Synthetic campaign (seed {cfg.seed})")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        (tmp / "traces").mkdir()
        for name, text in files.items():
            (tmp / name).write_text(text)
        for name, data in bundled.items():
            (tmp / name).write_bytes(data)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o777 & ~umask)            # mkdtemp makes it private
        if out.exists():
            out.rmdir()
        os.replace(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return truth


def _rounded(obj, digits: int = 10):
    """Round every float in a JSON-like object to ``digits`` significant digits."""
    if isinstance(obj, dict):
        return {k: _rounded(v, digits) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_rounded(v, digits) for v in obj]
    if isinstance(obj, float) and np.isfinite(obj):
        return float(f"{obj:.{digits}g}")
    return obj


def _jsonable_config(cfg: CampaignConfig) -> dict:
    d = {}
    for f in dataclasses.fields(cfg):
        v = getattr(cfg, f.name)
        if dataclasses.is_dataclass(v):
            v = {k: (abs(x) if isinstance(x, complex) else x)
                 for k, x in dataclasses.asdict(v).items()}
        elif isinstance(v, tuple):
            v = [list(x) if isinstance(x, tuple) else x for x in v]
        d[f.name] = v
    return json.loads(json.dumps(d, default=lambda o: float(np.real(o))))


def campaign_hashes(folder: str | os.PathLike) -> dict:
    """SHA-256 of every file of a campaign folder (relative path -> hex)."""
    folder = Path(folder)
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}
