"""Heterodyne recordings of a campaign: photodiode traces, their tone powers, bundled raw traces.

Every trace has its own random stream (purpose 4, amplitude index, dpd), so
any trace of the grid can be regenerated from the seed string recorded in
``traces.csv`` (:func:`regenerate_trace`), and an amplitude listed again is a
further recording with streams of its own.
"""

from __future__ import annotations

import dataclasses
import functools
import io
import zipfile

import numpy as np
import pandas as pd

from dpdfit.errors import InputError
from dpdfit.fits.tones import trace_tone_powers
from dpdfit.simulation.aom_truth import BraggAOM

from .calibration_runs import calibration_runs
from .config import CampaignConfig, rng_for
from .optics import dpd_lut, trace_field

__all__ = ["generate_trace", "direct_tones", "tone_readout", "regenerate_trace",
           "spectra_tables"]


def generate_trace(cfg: CampaignConfig, aom: BraggAOM, lut, A: float, dpd: int,
                   seed_key: tuple) -> tuple[np.ndarray, float]:
    """One heterodyne photodiode trace (float64, volts) and its power factor.

    The Cardioid(1,2) envelope (one 50 us period at ``fs``, tiled) is
    predistorted through the day's lookup table by linear interpolation (as
    an AWG table would), passed through the physical AOM, beaten against the
    reference at ``f_det`` (``Re[y e^{i 2 pi f_det t}]``, 1 V per unit field),
    scaled by the laser-power jitter and given white detector noise.
    """
    rng = rng_for(cfg, *seed_key)
    y = trace_field(cfg, aom, lut, A, dpd)
    per = y.size
    reps = -(-cfg.n_samples // per)
    y = np.tile(y, reps)[:cfg.n_samples]
    n = np.arange(cfg.n_samples)
    power = 10 ** (cfg.power_jitter_db * rng.standard_normal() / 20)
    phase0 = rng.uniform(0, 2 * np.pi)
    carrier = np.exp(1j * (2 * np.pi * (cfg.f_det / cfg.fs) * n + phase0))
    trace = power * (y * carrier).real + cfg.trace_noise_rms * rng.standard_normal(cfg.n_samples)
    return trace, power


@functools.cache
def _flattop_enbw() -> float:
    """Equivalent noise bandwidth (bins) of the flat-top window of the extraction (a
    constant, computed once: a window of 65,536 samples at every tone readout was a
    large part of a harness campaign's spectra, ``benchmarks/simulate_spectra_speed.json``)."""
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
    :func:`dpdfit.fits.tones.trace_tone_powers`; validity follows its SNR
    rules (20 dB for gate tones, 10 dB for IM tones).
    """
    return tone_readout(cfg, trace_field(cfg, aom, lut, A, dpd), rng_for(cfg, *seed_key))


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
    _, _, aom, tf, _ = calibration_runs(cfg)
    x, _ = generate_trace(cfg, aom, dpd_lut(tf, cfg.lut_points), float(cfg.trace_amplitudes[i]),
                          d, (4, i, d))
    return _int16(x)


def _int16(trace: np.ndarray) -> tuple[np.ndarray, float]:
    scale = float(np.max(np.abs(trace))) / 32000.0
    return np.round(trace / scale).astype(np.int16), scale


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


def _direct_rows(cfg, aom, lut, A, d, key) -> list:
    """``spectra.csv`` rows of one grid point from :func:`direct_tones`."""
    rows = []
    tones = direct_tones(cfg, aom, lut, float(A), d, key)
    for sb in ("red", "blue"):
        P, valid, snr = tones[sb]
        for j, nn in enumerate(cfg.spectra_harmonics):
            rows.append({"A": float(A), "dpd": d, "sideband": sb, "n": int(nn),
                         "P_dB": float(P[j]), "valid": int(valid[j]),
                         "snr_db": float(snr[j])})
    return rows


def _trace_rows(cfg, aom, lut, A, d, key):
    """``spectra.csv`` rows of one grid point extracted from its int16 trace, and the trace."""
    rows = []
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
    return rows, q, scale


def spectra_tables(cfg: CampaignConfig, aom: BraggAOM, lut, progress, first: int = 0):
    """All traces of the grid: ``spectra.csv`` and ``traces.csv`` tables, bundled raw traces
    (file name -> ``.npz`` bytes).

    An amplitude that ``cfg.trace_amplitudes`` lists again is recorded again, as a lab
    repeats a recording: further traces of that amplitude, each from the stream of its
    own index, their rows appended in the order of the list (``spectra.csv`` then has
    repeated rows of those tones, :mod:`dpdfit.recordings.spectra`).  Only the first
    recording of a bundled amplitude is bundled.  ``first``: record only the amplitudes
    from that index of ``cfg.trace_amplitudes`` on (exactly their rows of the whole list:
    each trace has its own stream).
    """
    rows, index, bundled = [], [], {}
    items = [(i, A, d) for i, A in enumerate(cfg.trace_amplitudes) for d in (0, 1)
             if i >= first]
    with progress("heterodyne traces", len(items)) as p:
        for i, A, d in items:
            key = (4, i, d)
            if cfg.spectra_mode == "direct":
                rows += _direct_rows(cfg, aom, lut, A, d, key)
                p.update()
                continue
            trace_rows, q, scale = _trace_rows(cfg, aom, lut, A, d, key)
            rows += trace_rows
            seed_str = f"{cfg.seed}:4:{i}:{d}"
            first = not any(abs(A - a) < 1e-9 for a in cfg.trace_amplitudes[:i])
            if first and any(abs(A - a) < 1e-9 and d == dd for a, dd in cfg.bundled_traces):
                fname = f"traces/trace_A{A:.3f}_dpd{d}.npz"
                bundled[fname] = _npz_bytes({"trace": q, "scale": np.array(scale)})
                index.append({"file": fname, "A": float(A), "dpd": d, "fs": cfg.fs,
                              "fdet": cfg.f_det, "nu": cfg.nu, "xi0": cfg.xi0_spec,
                              "n_samples": cfg.n_samples, "seed": seed_str})
            p.update()
    return pd.DataFrame(rows), pd.DataFrame(index), bundled
