"""The optical field of a campaign: RF envelope, predistortion table, AOM, beam path, gate tones."""

from __future__ import annotations

import numpy as np

from dpdfit.models.gate_sim import field_amplitudes
from dpdfit.models.transfer import TransferFunction, predistortion_table
from dpdfit.models.waveforms import cardioid, sample_grid, synthesize
from dpdfit.simulation.aom_truth import BraggAOM

from .config import CampaignConfig

__all__ = ["optical_field", "dpd_lut", "drive_envelope", "trace_field",
           "gate_spectrum"]


def optical_field(cfg: CampaignConfig, aom: BraggAOM, x: np.ndarray, fs: float) -> np.ndarray:
    """The optical field of one period of RF drive ``x`` at ``fs``: the injected effects'
    drive hooks, the (memoryless) AOM, the injected effects' field hooks
    (:meth:`dpdfit.simulation.injections.Injection.inject_drive`,
    ``inject_field``)."""
    injected = cfg.injections()
    for e, v in injected:
        x = e.inject_drive(v, x, fs)
    y = aom.field(x)
    for e, v in injected:
        y = e.inject_field(v, y, x, fs, aom.true_A_corr)
    return y


def dpd_lut(tf: TransferFunction, points: int):
    """The predistortion lookup table ``(target, rf)`` of the AWG (``points`` rows)."""
    target, rf, _ = predistortion_table(tf, points)
    return target, rf


def _predistort(env: np.ndarray, lut) -> np.ndarray:
    """RF samples through the lookup table by linear interpolation (as an AWG table would)."""
    target, rf_tab = lut
    return np.sign(env) * np.interp(np.abs(env), target, rf_tab)


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
        env = _predistort(env, lut)
    return env


def trace_field(cfg: CampaignConfig, aom: BraggAOM, lut, A: float, dpd: int) -> np.ndarray:
    """One gate period (``fs / xi0_spec`` samples) of the optical field envelope."""
    return optical_field(cfg, aom, drive_envelope(cfg, A, lut, dpd), cfg.fs)


def gate_spectrum(cfg: CampaignConfig, aom: BraggAOM, lut, A: float, dpd: int):
    """Harmonics ``n`` and complex tone amplitudes ``(b, c)`` (blue, red; the gate
    engine's positive-frequency convention) of the optical field for the gate waveform."""
    tones = cardioid()
    grid = sample_grid(cfg.nu, cfg.xi0_spec, tones)
    w = synthesize(tones, grid, A)
    if dpd:
        w = _predistort(w, lut)
    y = optical_field(cfg, aom, w, grid.fs)
    spec = np.fft.fft(y) / grid.n_samples
    n = np.asarray(cfg.harmonics_gate)
    kb, kr = grid.tone_bins(n)
    b, c = field_amplitudes(spec[kb], spec[kr])        # engine's positive-frequency convention
    return n, b, c
