"""Steps ``sweep``, ``spectra`` and ``traces`` of ``dpdfit analyze``: the spectral side.

``sweep`` simulates the amplitude sweep of the calibration at the spectra's
``nu``, ``xi0`` (S6); ``spectra`` analyses the recorded tone powers against it
(:func:`dpdfit.analyses.measured_spectra.measured_spectra`); ``traces``
re-analyses the bundled raw heterodyne traces and checks them against
``spectra.csv``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from dpdfit.analyses.measured_spectra import measured_spectra
from dpdfit.analyses.sweep import SweepConfig, run_sweep, thresholds
from dpdfit.errors import InputError
from dpdfit.fits.tones import trace_tone_powers
from dpdfit.models.transfer import TransferFunction
from dpdfit.recordings.traces import load_trace

from ..context import Context
from .calibration import CalibrationFits

__all__ = ["sweep_step", "spectra_step", "traces_step", "SimulatedSweep", "MeasuredSpectra",
           "TracesCheck", "sweep_summary", "spectra_summary", "traces_summary"]


@dataclass(frozen=True)
class SimulatedSweep:
    """What the sweep step made: the simulated sweep (``sweep.csv``), the configuration
    it was simulated at and its threshold efficiencies."""

    table: pd.DataFrame
    config: SweepConfig
    thresholds: dict


@dataclass(frozen=True)
class MeasuredSpectra:
    """What the spectra step made: the measured-spectra table and its headline numbers."""

    table: pd.DataFrame
    headline: dict


@dataclass(frozen=True)
class TracesCheck:
    """What the traces step made: the re-analysed tones beside spectra.csv's."""

    table: pd.DataFrame
    n_traces: int


def sweep_summary(sweep: SimulatedSweep) -> dict:
    """The ``sweep`` section of ``summary.json``: the threshold efficiencies."""
    return sweep.thresholds


def spectra_summary(m: MeasuredSpectra) -> dict:
    """The ``spectra`` section of ``summary.json``: the measured spectra's headline
    numbers, ``{"n_amplitudes", "R10_gain_dB_below_A_corr", "thresholds_measured"}``."""
    return m.headline


def traces_summary(t: TracesCheck) -> dict:
    """The ``traces`` section of ``summary.json``: the number of re-analysed traces and
    the largest ``|difference|`` (dB) of their tone powers to ``spectra.csv``'s."""
    diff = t.table["difference_dB"].abs().max() if len(t.table) else np.nan
    return {"n_traces": t.n_traces, "max_abs_difference_to_spectra_csv_dB": float(diff)}


def sweep_step(ctx: Context, fits: CalibrationFits | None) -> SimulatedSweep | None:
    """The simulated sweep of the calibration -> ``sweep.csv`` (its figures come at the end)."""
    res = ctx.results
    if fits is None:
        res.status("sweep", "skipped", "needs the calibration")
        return None
    camp = ctx.meta
    cfg = SweepConfig(nu=camp["nu_hz"], xi0=camp["xi0_spectra_hz"], nbar=camp["nbar_assumed"],
                      eta_ref=camp["eta_ref"], formula=ctx.formula)
    df = run_sweep(TransferFunction.from_calibration(fits.calibration), cfg)
    res.table("sweep.csv", df, dict(df.attrs))
    res.status("sweep", "ok", f"{len(cfg.amplitudes)} amplitudes x 2 flags, formula {ctx.formula}")
    return SimulatedSweep(table=df, config=cfg, thresholds=thresholds(df))


def spectra_step(ctx: Context, sweep: SimulatedSweep | None) -> MeasuredSpectra | None:
    """Measured tone powers: R10, R23, dP_n, F_est, eta_bar, thresholds
    -> ``spectra_measured.csv``."""
    res = ctx.results
    if not ctx.campaign.has("spectra.csv"):
        res.status("spectra", "skipped", "spectra.csv not found")
        return None
    m, summary = measured_spectra(ctx.campaign.spectra, None if sweep is None else sweep.table,
                                  nbar=ctx.meta["nbar_assumed"],
                                  formula=ctx.formula)
    res.table("spectra_measured.csv", m)
    res.status("spectra", "ok", f"{summary['n_amplitudes']} amplitudes with both flags")
    return MeasuredSpectra(table=m, headline=summary)


def _trace_rows(folder, i, r, idx_path, raw) -> list[dict]:
    """Tone powers of one listed trace, with the same tone's power in ``spectra.csv``: the
    reading of the trace's repeat (``r["repeat"]``, :func:`_trace_repeats`)."""
    f = folder / r["file"]
    if not f.exists():
        raise InputError(f"listed trace file '{r['file']}' not found", file=str(idx_path),
                         column="file", row=i + 1)
    t = trace_tone_powers(load_trace(f, within=folder), r["fs"], r["fdet"], r["nu"], r["xi0"])
    rows = []
    for sb in ("red", "blue"):
        tones = getattr(t, sb)
        for n in t.harmonics:
            ref = np.nan
            if raw is not None:
                s = raw[np.isclose(raw.A, r["A"]) & (raw.dpd == int(r["dpd"]))
                        & (raw.sideband == sb) & (raw.n == n) & (raw.repeat == r["repeat"])]
                ref = float(s["P_dB"].iloc[0]) if len(s) else np.nan
            rows.append({"file": r["file"], "A": r["A"], "dpd": int(r["dpd"]),
                         "repeat": r["repeat"], "sideband": sb, "n": int(n),
                         "P_dB": tones.P_dB[n], "valid": int(tones.valid[n]),
                         "P_dB_in_spectra_csv": ref, "difference_dB": tones.P_dB[n] - ref})
    return rows


def _trace_repeats(idx: pd.DataFrame, raw: pd.DataFrame | None) -> pd.DataFrame:
    """``traces.csv`` with the repeat of ``spectra.csv`` each trace was recorded as: its own
    ``repeat`` column, else the k-th trace listed of an ``(A, dpd)`` is that setting's
    k-th repeat in ``spectra.csv`` (the repeats in the order of their first row)."""
    idx = idx.copy()
    if "repeat" in idx.columns:
        idx["repeat"] = idx["repeat"].astype(str)
        return idx
    order = {}
    if raw is not None:
        for (A, d), g in raw.groupby(["A", "dpd"], sort=False):
            order[(float(A), int(d))] = list(dict.fromkeys(g["repeat"]))

    def label(A, d, j):
        ls = next((v for (a, dd), v in order.items() if dd == d and np.isclose(a, A)), [])
        return ls[j] if j < len(ls) else str(j + 1)

    k = idx.groupby(["A", "dpd"], sort=False).cumcount().to_numpy()
    idx["repeat"] = [label(A, int(d), j) for A, d, j in zip(idx["A"].to_numpy(float),
                                                             idx["dpd"].to_numpy(), k)]
    return idx


def traces_step(ctx: Context):
    """The raw traces re-analysed and checked against ``spectra.csv`` -> ``traces_check.csv``."""
    res, folder = ctx.results, ctx.folder
    idx_path = folder / "traces.csv"
    if not idx_path.exists():
        res.status("traces", "skipped", "traces.csv not found")
        return
    idx = ctx.campaign.traces
    # the spectra as the spectra step read them; a spectra file that step refused
    # leaves the traces unchecked against it (the spectra step reports why)
    raw = None
    if ctx.campaign.has("spectra.csv"):
        try:
            raw = ctx.campaign.spectra
        except InputError:
            raw = None
    idx = _trace_repeats(idx, raw)
    rows = [row for i, r in idx.iterrows() for row in _trace_rows(folder, i, r, idx_path, raw)]
    chk = pd.DataFrame(rows)
    res.table("traces_check.csv", chk)
    res.status("traces", "ok", f"{len(idx)} raw traces re-analysed")
    return TracesCheck(table=chk, n_traces=int(len(idx)))
