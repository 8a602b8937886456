"""Steps ``calibration`` and ``stability`` of ``dpdfit analyze``: the calibration runs.

The calibration step fits every amplitude and phase run once and hands the
fits down (:class:`CalibrationFits`): the stability step and the propagation
reuse them instead of refitting the same runs.  A fit is reused only where it
is the same fit (same run, order and window), so the numbers are unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from dpdfit.analyses.stability import missing_stability_columns, stability
from dpdfit.core.defaults import AMPLITUDE_ORDER
from dpdfit.fits.calibration import Calibration, calibrate_amplitude, calibrate_phase
from dpdfit.fits.photodiode import model_run_with_noise, phase_run_with_noise
from dpdfit.recordings.calibration_runs import list_runs
from dpdfit.report.calibration_plots import calibration_figures
from dpdfit.report.stability_plots import stability_figures

from ..context import Context

__all__ = ["CalibrationFits", "StabilityResults", "calibration_step", "stability_step",
           "calibration_summary", "stability_summary"]

#: orders of the AIC/BIC table of the predistortion table's run
_ORDER_SCAN = range(4, 13)


@dataclass(frozen=True)
class CalibrationFits:
    """What the calibration step hands down.

    ``calibration``: the predistortion table's amplitude run (with the
    photodiode's noise model when the file has no ``power_err``, and the
    AIC/BIC order table) and the model's phase run.  ``amplitude_runs`` /
    ``phase_runs``: every run's own fit, ``{run label: fit}`` (amplitude at
    order ``order``, phase with the default order and window).
    """

    calibration: Calibration
    order: int
    amplitude_runs: dict
    phase_runs: dict
    runs_table: pd.DataFrame | None = None
    noise: object = None
    phase_noise: object = None

    def amplitude_fits(self, order: int) -> dict | None:
        """The per-run amplitude fits if they were made at ``order`` (else None: refit)."""
        return self.amplitude_runs if order == self.order else None


def _amplitude_run_fits(cf, order, table_fit, table_data) -> dict:
    """Every amplitude run's fit at ``order``, ``{label: fit}`` (label None: a single run);
    the table's run is the table fit itself when it was fitted to the same data."""
    return {r: table_fit if _same_data(data, table_data) else calibrate_amplitude(data, order)
            for r, data in cf.amplitude_run_data.items()}


def _phase_run_fits(cf, model_fit, model_data) -> dict:
    """Every phase run's fit (default order and window), ``{label: fit}``; the model's run
    is the model fit itself when it was fitted to the same data."""
    return {r: model_fit if _same_data(data, model_data) else calibrate_phase(data)
            for r, data in cf.phase_run_data.items()}


def _same_data(a, b) -> bool:
    """The same run with the same points and errors (the model run gets learnt errors
    when the file has none: then it is another fit)."""
    if a.run != b.run or a.source != b.source or len(a.A) != len(b.A):
        return False
    same_err = (a.error is None and b.error is None) or (
        a.error is not None and b.error is not None and np.array_equal(a.error, b.error))
    return same_err and np.array_equal(a.A, b.A) and np.array_equal(a.value, b.value)


def _runs_table(amp_fits: dict, ph_fits: dict) -> pd.DataFrame:
    """``calibration_runs.csv``: y(1) of every amplitude run, phi(1) of every phase run."""
    rows = [{"kind": "amplitude", "run": r, "timestamp": c.source.get("timestamp"),
             "value": c.A_corr, "stderr": c.A_corr_stderr, "quantity": "A_corr",
             "monotone": int(c.monotone), "reduced_chi2": c.reduced_chi2}
            for r, c in amp_fits.items()]
    rows += [{"kind": "phase", "run": r, "timestamp": c.source.get("timestamp"),
              "value": c.phi_at_1, "stderr": c.phi_at_1_stderr, "quantity": "phi_at_1",
              "monotone": None, "reduced_chi2": c.reduced_chi2}
             for r, c in ph_fits.items()]
    return pd.DataFrame(rows)


def _summary(cal: Calibration, runs_df: pd.DataFrame, noise, ph_noise) -> dict:
    amp, ph = cal.amplitude, cal.phase
    a = runs_df[runs_df.kind == "amplitude"]["value"]
    p = runs_df[runs_df.kind == "phase"]["value"]
    out = {
        "lut_run": amp.source.get("run"), "A_corr": amp.A_corr,
        "A_corr_stderr": amp.A_corr_stderr, "monotone": amp.monotone,
        "phi_at_1": None if ph is None else ph.phi_at_1,
        "phi_at_1_stderr": None if ph is None else ph.phi_at_1_stderr,
        "n_amplitude_runs": int(a.size), "A_corr_runs_mean": float(a.mean()),
        "A_corr_runs_std": float(a.std(ddof=1)) if a.size > 1 else None,
        "n_phase_runs": int(p.size),
        "phi_at_1_runs_mean": float(p.mean()) if p.size else None,
        "phi_at_1_runs_std": float(p.std(ddof=1)) if p.size > 1 else None,
    }
    if noise is not None or ph_noise is not None:
        out["noise_model"] = {"power": None if noise is None else noise.to_dict(),
                              "phase": None if ph_noise is None else ph_noise.to_dict()}
    return out


def calibration_step(ctx: Context) -> CalibrationFits | None:
    """Fits of the table's run, the model's phase run and every run -> ``calibration.json``,
    ``calibration_runs.csv``, Fig. 1."""
    cf, res = ctx.campaign, ctx.results
    if not cf.has("calibration_amplitude.csv"):
        res.status("calibration", "skipped", "calibration_amplitude.csv not found")
        return None
    order = ctx.meta["order"]
    runs = list_runs(cf.amplitude_runs)
    # the table run, with the photodiode's noise learnt from all runs when the file
    # has no power_err (the same rule as the diagnosis: dpdfit.fits.photodiode)
    amp_data, noise = model_run_with_noise(cf)
    amp = calibrate_amplitude(amp_data, order, order_scan=_ORDER_SCAN)
    amp_fits = _amplitude_run_fits(cf, order, amp, amp_data)
    ph = ph_data = ph_noise = None
    ph_fits = {}
    if cf.has("calibration_phase.csv"):
        ph_data, ph_noise = phase_run_with_noise(cf)
        ph = calibrate_phase(ph_data)
        ph_fits = _phase_run_fits(cf, ph, ph_data)
    cal = Calibration(amplitude=amp, phase=ph)
    res.json_file("calibration.json", cal.to_dict())
    runs_df = _runs_table(amp_fits, ph_fits)
    res.table("calibration_runs.csv", runs_df)
    ctx.figure(calibration_figures, cal, amp_data, ph_data)
    res.status("calibration", "ok", f"amplitude run {amp.source.get('run')}, "
                                    f"{len(runs) or 1} amplitude / {len(ph_fits)} phase runs fitted")
    return CalibrationFits(calibration=cal, order=order, amplitude_runs=amp_fits,
                           phase_runs=ph_fits, runs_table=runs_df, noise=noise,
                           phase_noise=ph_noise)


def calibration_summary(fits: CalibrationFits) -> dict:
    """The ``calibration`` section of ``summary.json``."""
    return _summary(fits.calibration, fits.runs_table, fits.noise, fits.phase_noise)


def _stability_fits(fits: CalibrationFits | None, kind: str) -> dict | None:
    """The calibration step's run fits where they are the stability's own (default order)."""
    if fits is None:
        return None
    return fits.amplitude_fits(AMPLITUDE_ORDER) if kind == "amplitude" else fits.phase_runs


def stability_step(ctx: Context, fits: CalibrationFits | None) -> "StabilityResults | None":
    """y(1) and phi(1) per run: mean, sd, drift test, Allan deviation (S2) ->
    ``stability_*.json``, Figs. S1, S2.  A file without ``run`` or ``timestamp``
    (optional columns) is skipped, with the reason."""
    res = ctx.results
    done, done_kinds, skipped = [], {}, []
    cf = ctx.campaign
    for kind, name in (("amplitude", "calibration_amplitude.csv"),
                       ("phase", "calibration_phase.csv")):
        if not cf.has(name):
            continue
        runs = cf.amplitude_runs if kind == "amplitude" else cf.phase_runs
        missing = missing_stability_columns(runs)
        if missing:
            skipped.append(f"{name} has no {' or '.join(missing)} column (the stability "
                           "needs run and timestamp)")
            continue
        st = stability(runs, kind=kind, fits=_stability_fits(fits, kind))
        res.json_file(f"stability_{kind}.json", st.to_dict())
        done_kinds[kind] = st
        ctx.figure(stability_figures, st)
        done.append(f"{kind}: {st.n_runs} runs, sd {st.std:.3g}, trend "
                    f"{st.trend_per_day:+.2e} +/- {st.trend_per_day_err:.1e} /day")
    if not done:
        res.status("stability", "skipped", "; ".join(skipped) or "no calibration files")
        return None
    res.status("stability", "ok", "; ".join(done + [f"skipped: {s}" for s in skipped]))
    return StabilityResults(done_kinds)


@dataclass(frozen=True)
class StabilityResults:
    """What the stability step made: ``{kind: StabilityResult}`` (amplitude, phase)."""

    by_kind: dict


def stability_summary(st: StabilityResults) -> dict:
    """The ``stability`` section of ``summary.json``."""
    keys = ("mean", "std", "relative_std", "n_runs", "span_days", "trend_per_day",
            "trend_per_day_err")
    out = {}
    for kind, r in st.by_kind.items():
        d = r.to_dict()
        out[kind] = {k: d[k] for k in keys}
    return out
