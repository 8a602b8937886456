"""Recorded observables of a campaign, standardised for the discrepancy diagnosis (issue #7).

Reads a campaign folder (layout of :mod:`dpdfit.campaign`) into the
quantities that the forward model predicts, each with a 1-sigma error that
contains every known noise source and nothing else:

* **tone features** per trace (``spectra.csv``): ``R10 = P1 - P0``,
  ``R23 = P2 - P3``, ``R5lo = P1 - P(-1)`` and ``R5hi = P2 - P4`` (IM5),
  ``gate_balance = P2 - P1`` per sideband, ``red_blue`` (mean red minus mean
  blue gate tone) and ``gate_power`` (mean gate tone minus ``20 log10 A``, up
  to a constant).  Ratios within one trace cancel its laser-power jitter;
  ``gate_power`` carries it (``power_jitter_db`` of the lab's error model).
  Tone powers are debiased for the noise in their bin: the extraction's
  floor is the *median* noise power, the mean is ``floor / ln 2``
  (:mod:`dpdfit.heterodyne`), so ``P = |c|^2 + N0`` and the error of a
  tone at SNR ``s`` is ``(10/ln 10) sqrt(2 N0 / P)`` dB.  Tones below
  ``MIN_SNR_DB`` are not used (their reading is an upper limit).
* **gate observables** per setting ``(A, dpd)``, pooled over the scans:
  population fidelity ``F_pop = P00 + P11``, imbalance ``P00 - P11`` and the
  mean of the scans' parity contrasts (binomial MLE per scan, :mod:`dpdfit.counts`;
  not the count-level merge, whose contrast the scans' power jitter washes out).
* **time scans**: ``P00`` and ``P11`` at each scan time (binomial).
* **calibration residuals** of the model's own amplitude and phase runs.

Everything here is measured; predictions live in :mod:`dpdfit.effects`.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from .calibration import calibrate_amplitude, calibrate_phase
from .counts import fit_parity, read_parity, read_populations
from .errors import InputError
from .tables import read_calibration, read_table

__all__ = ["Campaign", "load_campaign", "tone_features", "TONE_FEATURES", "MIN_SNR_DB"]

#: tones weaker than this above the (median) floor are not used
MIN_SNR_DB = 15.0
#: extraction error floor of a tone power (flat-top scalloping, dB)
EXTRACTION_FLOOR_DB = 0.01
#: per-trace tone features: name -> (sideband-resolved, harmonics used)
TONE_FEATURES = {
    "R10": (True, (1, 0)), "R23": (True, (2, 3)), "R5lo": (True, (1, -1)),
    "R5hi": (True, (2, 4)), "gate_balance": (True, (2, 1)),
    "red_blue": (False, (1, 2)), "gate_power": (False, (1, 2)),
}
DEFAULT_ERROR_MODEL = {"nbar": 0.1, "T2_s": 50e-3, "heating_quanta_per_s": 5.0,
                       "p_prep": 0.003, "p_det": 5e-5, "power_jitter_db": 0.2,
                       "xi0_rel_err": 0.01}
HARMONICS = (-1, 0, 1, 2, 3, 4)
SIDEBANDS = ("red", "blue")


@dataclass(frozen=True)
class Campaign:
    """A campaign's recordings and the lab's own model inputs.

    Attributes
    ----------
    folder : Path
    meta : dict
        ``campaign.json``.
    amplitude, phase : calibration results of the model's runs (phase may be None)
    amp_residuals, phase_residuals : pandas.DataFrame
        ``A, z`` standardised fit residuals of those runs.
    A_tones : ndarray
        Amplitudes of the spectra grid.
    P_dB, sd_dB : ndarray, shape (nA, 2 dpd, 2 sideband, len(HARMONICS))
        Debiased tone powers and their errors (NaN where unusable).
    gates : pandas.DataFrame
        Per setting: ``A, dpd, xi0_hz, xi0_rel_err, n_scans`` and the measured
        ``F_pop, imb, C`` with shot-noise errors ``*_shot``.
    time_scans : pandas.DataFrame
        ``A, dpd, t_s, n00, n11, shots``.
    error_model : dict
        The lab's error model (``campaign.json`` ``error_model``, else defaults).
    warnings : tuple of str
        One line each, e.g. a non-monotone model calibration.
    """

    folder: Path
    meta: dict
    amplitude: object
    phase: object
    amp_residuals: pd.DataFrame
    phase_residuals: pd.DataFrame | None
    A_tones: np.ndarray
    P_dB: np.ndarray
    sd_dB: np.ndarray
    gates: pd.DataFrame | None
    time_scans: pd.DataFrame | None
    error_model: dict = field(default_factory=dict)
    warnings: tuple = ()

    @property
    def nu(self) -> float:
        return float(self.meta.get("nu_hz", 1.84e6))

    @property
    def xi0_spectra(self) -> float:
        return float(self.meta.get("xi0_spectra_hz", 20e3))


def _residual_frame(cal, A, value, err) -> pd.DataFrame:
    pred = cal.power(A) if hasattr(cal, "power") else cal.phi(A)
    if err is None:
        err = np.full_like(value, np.std(value - pred))
    return pd.DataFrame({"A": A, "z": (value - pred) / err})


def _calibrations(folder: Path, meta: dict):
    amp_run = (meta.get("predistortion_table") or {}).get("amplitude_run") or "latest"
    data = read_calibration(folder / "calibration_amplitude.csv", "amplitude", amp_run)
    amp = calibrate_amplitude(data, int(meta.get("order", 8)))
    amp_res = _residual_frame(amp, data.A, data.value, data.error)
    ph, ph_res = None, None
    path = folder / "calibration_phase.csv"
    if path.exists():
        pdata = read_calibration(path, "phase", meta.get("phase_run_for_model") or "latest")
        ph = calibrate_phase(pdata)
        use = pdata.A >= 0.1
        ph_res = _residual_frame(ph, pdata.A[use], pdata.value[use],
                                 None if pdata.error is None else pdata.error[use])
    return amp, amp_res, ph, ph_res


def _tones(path: Path):
    df = read_table(path, ["A", "dpd", "sideband", "n", "P_dB"], ["valid", "snr_db"],
                    numeric=["A", "dpd", "n", "P_dB"], ranges={"A": (0, 1), "dpd": (0, 1)})
    if "snr_db" not in df.columns:
        raise InputError("the diagnosis needs the snr_db column (noise floor of each tone)",
                         file=str(path), column="snr_db")
    bad = ~df["sideband"].isin(SIDEBANDS)
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        raise InputError(f"sideband must be red or blue, got '{df['sideband'].iloc[i]}'",
                         file=str(path), column="sideband", row=i + 1)
    A = np.unique(df["A"].to_numpy(dtype=float))
    P = np.full((A.size, 2, 2, len(HARMONICS)), np.nan)
    sd = np.full_like(P, np.nan)
    iA = np.searchsorted(A, df["A"].to_numpy(dtype=float))
    d = df["dpd"].to_numpy(dtype=int)
    s = (df["sideband"] == "blue").to_numpy(dtype=int)
    n = df["n"].to_numpy(dtype=int)
    keep = np.isin(n, HARMONICS)
    h = np.searchsorted(HARMONICS, n[keep])
    p_db = df["P_dB"].to_numpy(dtype=float)[keep]
    snr = pd.to_numeric(df["snr_db"], errors="coerce").to_numpy(dtype=float)[keep]
    # mean noise power in the bin = median floor / ln 2
    N0 = 10 ** ((p_db - snr) / 10) / np.log(2)
    lin = 10 ** (p_db / 10) - N0
    ok = (snr >= MIN_SNR_DB) & (lin > 0) & np.isfinite(snr)
    val = np.where(ok, 10 * np.log10(np.where(ok, lin, 1.0)), np.nan)
    err = np.where(ok, np.hypot(10 / np.log(10) * np.sqrt(2 * N0 / np.where(ok, lin, 1.0)),
                                EXTRACTION_FLOOR_DB), np.nan)
    P[iA[keep], d[keep], s[keep], h] = val
    sd[iA[keep], d[keep], s[keep], h] = err
    return A, P, sd


def tone_features(P_dB: np.ndarray, A: np.ndarray, sd_dB: np.ndarray | None = None):
    """Per-trace features of tone powers (see module doc).

    Parameters
    ----------
    P_dB : ndarray, shape (nA, 2, 2, len(HARMONICS))
    A : ndarray, shape (nA,)
    sd_dB : ndarray, optional
        Errors of ``P_dB``; the features' errors are propagated (tones independent).

    Returns
    -------
    dict name -> (value, sd) with arrays of shape (nA, 2 dpd, 2 sideband) for
    sideband-resolved features and (nA, 2 dpd, 1) otherwise (``sd`` None if not given).
    """
    def tone(n):
        return P_dB[..., HARMONICS.index(n)]

    def var(n):
        return None if sd_dB is None else sd_dB[..., HARMONICS.index(n)] ** 2

    out = {}
    for name, (per_sb, (a, b)) in TONE_FEATURES.items():
        if per_sb:
            v = tone(a) - tone(b)
            e = None if sd_dB is None else np.sqrt(var(a) + var(b))
        elif name == "red_blue":
            g = 0.5 * (tone(1) + tone(2))                       # (nA, 2, 2)
            v = (g[..., 0] - g[..., 1])[..., None]
            e = None if sd_dB is None else 0.5 * np.sqrt(var(1).sum(-1) + var(2).sum(-1))[..., None]
        else:                                                   # gate_power
            g = 0.25 * (tone(1) + tone(2)).sum(-1)
            v = (g - 20 * np.log10(np.maximum(A, 1e-300))[:, None])[..., None]
            e = None if sd_dB is None else 0.25 * np.sqrt(var(1).sum(-1) + var(2).sum(-1))[..., None]
        out[name] = (v, e)
    return out


def _gates(folder: Path, meta: dict):
    pop_path, par_path = folder / "populations.csv", folder / "parity.csv"
    rate_path = folder / "gate_rates.csv"
    if not (pop_path.exists() and par_path.exists() and rate_path.exists()):
        return None
    pop = read_populations(pop_path)
    par = read_parity(par_path)
    rates = read_table(rate_path, ["A", "dpd", "xi0_khz"], ["xi0_err_khz"],
                       numeric=["A", "dpd", "xi0_khz"], positive=["xi0_khz"])
    if not {"n00", "n11"} <= set(pop.columns):
        raise InputError("the diagnosis needs n00 and n11 (imbalance)", file=str(pop_path),
                         column="n00")
    rows = []
    for (A, d), g in pop.groupby(["A", "dpd"]):
        r = rates[(np.isclose(rates.A, A)) & (rates.dpd == d)]
        if r.empty:
            raise InputError(f"no gate rate for A={A:g}, dpd={int(d)}", file=str(rate_path),
                             column="xi0_khz")
        N = float(g["shots"].sum())
        p00, p11 = g["n00"].sum() / N, g["n11"].sum() / N
        # contrast per scan, averaged: each scan's power error also moves its
        # fringe phase, so a count-level merge would wash the contrast out
        cs, es = [], []
        for _, sc in par[(np.isclose(par.A, A)) & (par.dpd == d)].groupby("scan"):
            f = fit_parity(sc["phase_rad"].to_numpy(), sc["n_even"].to_numpy(),
                           sc["shots"].to_numpy())
            cs.append(f.A)
            es.append(f.A_err)
        xi = float(r["xi0_khz"].iloc[0]) * 1e3
        rel = (float(r["xi0_err_khz"].iloc[0]) * 1e3 / xi if "xi0_err_khz" in r.columns
               else np.nan)
        pe = max(min(p00 + p11, 1 - 0.5 / N), 0.5 / N)
        rows.append({"A": float(A), "dpd": int(d), "xi0_hz": xi, "xi0_rel_err": rel,
                     "n_scans": int(g["scan"].nunique()), "shots": N,
                     "F_pop": p00 + p11, "F_pop_shot": np.sqrt(pe * (1 - pe) / N),
                     "imb": p00 - p11,
                     "imb_shot": np.sqrt(max(p00 + p11 - (p00 - p11) ** 2, 1.0 / N) / N),
                     "C": float(np.mean(cs)), "C_shot": float(np.sqrt(np.sum(np.square(es)))
                                                               / len(es))})
    return pd.DataFrame(rows).sort_values(["dpd", "A"], ignore_index=True)


def _time_scans(folder: Path):
    path = folder / "time_scans.csv"
    if not path.exists():
        return None
    df = read_table(path, ["A", "dpd", "t_us", "n00", "n11", "shots"], [],
                    numeric=["A", "dpd", "t_us", "n00", "n11", "shots"], positive=["shots"])
    df = df.assign(t_s=df["t_us"] * 1e-6, dpd=df["dpd"].astype(int))
    return df[["A", "dpd", "t_s", "n00", "n11", "shots"]].reset_index(drop=True)


def load_campaign(folder) -> Campaign:
    """Read and validate a campaign folder for the diagnosis."""
    folder = Path(folder)
    if not (folder / "campaign.json").exists():
        raise InputError("not a campaign folder: campaign.json missing", file=str(folder))
    try:
        meta = json.loads((folder / "campaign.json").read_text())
    except json.JSONDecodeError as exc:
        raise InputError(f"campaign.json is not valid JSON ({exc.msg}, line {exc.lineno})",
                         file=str(folder / "campaign.json")) from None
    amp, amp_res, ph, ph_res = _calibrations(folder, meta)
    warnings = []
    if not amp.monotone:
        iv = ", ".join(f"[{a:.3g}, {b:.3g}]" for a, b in amp.nonmonotone_intervals)
        warnings.append(f"{folder / 'calibration_amplitude.csv'}, run "
                        f"{amp.source.get('run', '?')}: amplitude calibration decreases on "
                        f"A in {iv}; the predistortion table clamps there")
    if not (folder / "spectra.csv").exists():
        raise InputError("the diagnosis needs spectra.csv", file=str(folder))
    A, P, sd = _tones(folder / "spectra.csv")
    em = dict(DEFAULT_ERROR_MODEL)
    em.update(meta.get("error_model") or {})
    return Campaign(folder=folder, meta=meta, amplitude=amp, phase=ph, amp_residuals=amp_res,
                    phase_residuals=ph_res, A_tones=A, P_dB=P, sd_dB=sd,
                    gates=_gates(folder, meta), time_scans=_time_scans(folder), error_model=em,
                    warnings=tuple(warnings))
