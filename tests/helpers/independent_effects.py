"""Independent implementations of two concealed effects, for the generalisation test
of the diagnosis.

The diagnosis' catalog (:mod:`dpdfit.analyses.diagnosis.effects`) models AOM memory as a single-pole
response and a stale calibration as an amplitude-axis scaling of the day's
calibration.  Here the same physical effects are produced by *different* code with
*different* functional forms, and only ``spectra.csv`` of a null campaign is
rewritten from it:

* :func:`memory_kernel_spectra` -- the modulator responds to its complex baseband
  drive through a critically damped two-pole kernel ``h(t) = t/tau^2 exp(-t/tau)``
  (``H(f) = 1/(1 + i 2 pi (f - f_off) tau)^2``, mean delay ``2 tau``), applied in the
  time domain with :func:`scipy.signal.lfilter` over several periods (periodic
  steady state = last period), with the response centred ``f_off`` away from the
  carrier (demodulate by ``exp(-i 2 pi f_off t)``, filter, remodulate).
* :func:`drift_profile_spectra` -- the predistortion table was made from a
  calibration run recorded ``ramp_days`` before the gate day, and the AOM has
  drifted *linearly in time* since: its compression (A_corr), its peak efficiency
  eta_ref and the *shape* of its amplifier compression
  (``u(A) -> u(A) + kappa A^2 (1 - A)``, which keeps u(0), u'(0), u(1)) all ramp
  linearly from their table-time values to the day's; the ramp continues while the
  spectra are recorded (each trace sees the AOM of its own time).

Neither uses :class:`~dpdfit.simulation.aom_truth.BraggAOM`'s memory nor :mod:`dpdfit.analyses.diagnosis.effects`.
Reused: the static BraggAOM (memory_tau=0), the calibration fit, the transfer
function and predistortion-table builders, ``simulate_amplitude_run``.  The tone
extraction (FFT bins, power jitter, complex noise of a flat-top estimate, floor =
median, SNR validity rules) follows :func:`dpdfit.simulation.campaign.direct_tones`, recoded.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.signal import lfilter

from dpdfit.simulation.aom_truth import BraggAOM, simulate_amplitude_run
from dpdfit.fits.calibration import fit_amplitude
from dpdfit.simulation.campaign import drive_envelope as campaign_drive_envelope
from dpdfit.simulation.campaign import simulate_campaign, tone_readout
from dpdfit.simulation.harness import _silent, harness_config
from dpdfit.models.transfer import TransferFunction, predistortion_table

ETA_REF = 0.8

# --------------------------------------------------------------------------- campaign


def null_campaign(folder, seed: int):
    """Simulate a null harness campaign into ``folder``; return (config, truth dict).

    ``truth.json`` is read (the day's AOM) and then deleted: the diagnosis never
    sees it, and it would describe the null campaign, not the rewritten spectra.
    """
    folder = Path(folder)
    cfg = harness_config(seed)
    simulate_campaign(folder, seed=seed, effects={}, config=cfg, progress=_silent)
    truth = json.loads((folder / "truth.json").read_text())
    (folder / "truth.json").unlink()
    return cfg, truth


def day_aom(truth: dict) -> BraggAOM:
    cal = truth["calibration"]
    return BraggAOM(A_corr=float(cal["day_A_corr"]), phi_1=float(cal["day_phi_at_1"]),
                    eta_ref=ETA_REF)


def lut_from_run(run: pd.DataFrame, order: int = 8, points: int = 4096):
    """Predistortion table (target, rf) from one amplitude run, as the campaign builds it."""
    fit = fit_amplitude(run["A"], run["power"], run["power_err"], order)
    tf = TransferFunction(fit.powers, fit.coefficients)
    target, rf, _ = predistortion_table(tf, points)
    return (target, rf), fit


def day_lut(folder, cfg):
    """The table the campaign used: from the last run of calibration_amplitude.csv."""
    amp = pd.read_csv(Path(folder) / "calibration_amplitude.csv")
    last = amp[amp.run == amp.run.iloc[-1]]
    return lut_from_run(last, cfg.order, cfg.lut_points)


# --------------------------------------------------------------------------- drive and tones


# The drive waveform and the heterodyne read-out (noise, floor, validity) are the
# simulator's own: what is implemented independently here are the *effects*.
drive_envelope = campaign_drive_envelope
extract_tones = tone_readout


def write_spectra(folder, cfg, field_of, seed_key: int):
    """Rewrite ``spectra.csv`` with the tones of ``field_of(i, A, dpd) -> field period``."""
    rows = []
    for i, A in enumerate(cfg.trace_amplitudes):
        for d in (0, 1):
            rng = np.random.default_rng(np.random.SeedSequence([cfg.seed, seed_key, i, d]))
            tones = extract_tones(cfg, field_of(i, float(A), d), rng)
            for sb in ("red", "blue"):
                P, valid, snr = tones[sb]
                for j, nn in enumerate(cfg.spectra_harmonics):
                    rows.append({"A": float(A), "dpd": d, "sideband": sb, "n": int(nn),
                                 "P_dB": float(P[j]), "valid": int(valid[j]),
                                 "snr_db": float(snr[j])})
    df = pd.DataFrame(rows)
    (Path(folder) / "spectra.csv").write_text(
        df.to_csv(index=False, float_format="%.10g", lineterminator="\n"))
    return df


# --------------------------------------------------------------------------- variant 1: memory


def two_pole_response(x: np.ndarray, fs: float, tau: float, f_off: float,
                      periods: int = 3) -> np.ndarray:
    """Periodic steady state of a critically damped two-pole modulator response.

    Continuous kernel ``h(t) = t/tau^2 exp(-t/tau)`` (unit area, mean delay 2 tau),
    discretised impulse-invariantly as two cascaded unit-DC-gain one-pole stages
    ``(1-a)^2 / (1 - a z^-1)^2``, ``a = exp(-1/(tau fs))``.  The response is centred
    at ``f_off`` from the carrier: the complex baseband drive is demodulated by
    ``exp(-i 2 pi f_off t)``, filtered by the real kernel and remodulated.  The
    period ``x`` is tiled ``periods`` times and the last period returned.
    """
    if tau <= 0:
        return np.asarray(x, dtype=complex)
    per = x.size
    xx = np.tile(np.asarray(x, dtype=complex), periods)
    t = np.arange(xx.size) / fs
    rot = np.exp(-2j * np.pi * f_off * t)
    a = np.exp(-1.0 / (tau * fs))
    b_coef, a_coef = [(1 - a) ** 2], [1.0, -2 * a, a * a]
    yy = lfilter(b_coef, a_coef, xx * rot) * np.conj(rot)
    return yy[-per:]


def memory_kernel_spectra(folder, cfg, truth, tau: float = 40e-9, f_off: float = 2.5e6,
                          seed_key: int = 91):
    """Rewrite spectra.csv of a null campaign: day's AOM behind a two-pole memory."""
    aom = day_aom(truth)
    lut, _ = day_lut(folder, cfg)

    def field_of(i, A, d):
        x = two_pole_response(drive_envelope(cfg, A, lut, d), cfg.fs, tau, f_off)
        return aom.field(x)

    return write_spectra(folder, cfg, field_of, seed_key)


# --------------------------------------------------------------------------- variant 2: drift


@dataclasses.dataclass(frozen=True)
class ShapedAOM(BraggAOM):
    """Static BraggAOM whose amplifier compression has a changed shape:
    ``u(A) + kappa A^2 (1 - A)`` (same u(0), u'(0) and u(1), hence same A_corr)."""

    kappa: float = 0.0

    def u(self, A):
        A = np.asarray(A, dtype=float)
        return super().u(A) + self.kappa * A * A * (1 - A)


def ramp_aom(truth: dict, frac: float, drift_rel: float, d_eta: float, kappa: float):
    """The AOM at ``frac`` of the way from the table's calibration (0) to the gate day (1).

    Linear in time: A_corr = day (1 + drift_rel (1 - frac)), eta_ref = 0.8 + d_eta (1 - frac),
    amplifier shape kappa (1 - frac); frac > 1 continues the ramp past the gate day.
    """
    cal = truth["calibration"]
    r = 1.0 - frac
    return ShapedAOM(A_corr=float(cal["day_A_corr"]) * (1 + drift_rel * r),
                     phi_1=float(cal["day_phi_at_1"]), eta_ref=ETA_REF + d_eta * r,
                     kappa=kappa * r)


def drift_profile_spectra(folder, cfg, truth, drift_rel: float = 0.02, d_eta: float = -0.04,
                          kappa: float = 0.03, ramp_days: float = 2.0,
                          recording_hours: float = 2.0, seed_key: int = 92):
    """Rewrite spectra.csv of a null campaign: stale table, AOM drifted linearly since.

    The table's calibration run is simulated at the start of the ramp (A_corr
    ``1 + drift_rel`` times the day's, eta_ref ``0.8 + d_eta``, shape ``kappa``) and
    fitted (order 8) into a 4096-point table; the spectra traces are recorded in
    order over ``recording_hours`` starting at the gate day, each through the AOM of
    its own time (static BraggAOM with the ramped shape).  campaign.json keeps
    claiming the table comes from the day's run.  Returns (spectra, table fit).
    """
    grid = np.round(np.linspace(0.0, 1.0, cfg.cal_points), 10)
    aom_t0 = ramp_aom(truth, 0.0, drift_rel, d_eta, kappa)
    run = simulate_amplitude_run(aom_t0, grid,
                                 np.random.default_rng(np.random.SeedSequence([cfg.seed, 93])),
                                 cfg.photodiode)
    lut, fit = lut_from_run(run, cfg.order, cfg.lut_points)
    n_tr = 2 * len(cfg.trace_amplitudes)

    def field_of(i, A, d):
        hours = recording_hours * (2 * i + d) / n_tr
        aom = ramp_aom(truth, 1.0 + hours / (24 * ramp_days), drift_rel, d_eta, kappa)
        return aom.field(drive_envelope(cfg, A, lut, d).astype(complex))

    return write_spectra(folder, cfg, field_of, seed_key), fit
