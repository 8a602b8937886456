"""`dpdfit analyze`: every analysis dpdfit has, run on a campaign folder.

Each analysis reads only the files it needs; a missing file skips that
analysis (with the reason in the summary), a malformed file stops that
analysis with the one-line error naming file, column and row, and the others
go on.  All outputs are staged and published together at the end, so a
previous results folder is never half-overwritten.

Analyses (in order):

1. ``calibration`` -- the amplitude run the day's predistortion table came
   from (``campaign.json``), the phase run used for the model; every
   amplitude and phase run for the per-run table.  -> ``calibration.json``,
   ``calibration_runs.csv``, Fig. 1.
2. ``sweep`` -- the simulated amplitude sweep from that calibration at the
   spectra's ``nu``, ``xi0`` (S6). -> ``sweep.csv``, Figs. 2, 5, S4, S6.
3. ``spectra`` -- measured tone powers (``spectra.csv``): ``R10``, ``R23``,
   ``dP_n``, ``F_est`` per A and flag, ``eta_bar`` from the simulation's
   spline (S6.5), measured threshold efficiencies
   (:mod:`dpdfit.analyses.measured_spectra`). -> ``spectra_measured.csv``,
   Figs. 2/S6/5 with measured (solid) and simulated (dashed) curves.
4. ``traces`` -- the bundled raw traces re-analysed and checked against
   ``spectra.csv``. -> ``traces_check.csv``.
5. ``stability`` -- y(1) and phi(1) per run: mean, sd, drift test, Allan
   deviation, curve envelopes (S2). -> ``stability_*.json``, Figs. S2, S3.
6. ``gates`` -- count inference (S7): population and parity fidelities per
   setting pooled over scans (``gate.csv``, joined with ``gate_rates.csv``),
   the alignment fit of ``alpha`` and ``delta`` against the simulated sweep
   (``alignment_points.csv``), Figs. 3, 4, S7, S8.
7. ``propagation`` -- emcee posterior of the day's amplitude calibration with
   the run-to-run drift model, 10^4 draws pushed through the sweep at
   A = 0.5 for a fresh and a 30-day-old table. -> ``propagation.json``.
8. ``budget`` -- the error budget of Table S3 (S8) from ``budget.toml`` in
   the campaign folder (or the paper's inputs), with the gate times from
   ``gate_rates.csv`` and ``delta`` from the alignment fit. -> ``budget.json``.
9. ``diagnosis`` -- the discrepancy diagnosis (unless ``diagnosis=False``).
   -> ``diagnosis.json``.

One pipeline: each step (:mod:`dpdfit.pipeline.steps`) gets what earlier
steps produced instead of recomputing it -- every calibration run is fitted
once (in ``calibration``; ``stability`` and ``propagation`` reuse the fits)
and the amplitude posterior is sampled once (``propagation``: the
propagation, the threshold distributions and the corner plot share it).  The
Markdown summary is written by :mod:`dpdfit.report.summary`.
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

from dpdfit.core.defaults import FORMULA
from dpdfit.errors import DpdfitError, InputError
from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.recordings.outputs import staged_outputs, to_jsonable
from dpdfit.report.summary import PAPER, realism_table, summary_markdown
from dpdfit.report.sweep_plots import sweep_figures

from .context import Context, Results
from .steps import (budget_step, calibration_step, diagnosis_step, gates_step, propagation_step,
                    spectra_step, stability_step, sweep_step, traces_step)

__all__ = ["analyze", "PAPER"]


def _step(label):
    print(f"[analyze] {label} ...", file=sys.stderr, flush=True)
    return time.perf_counter()


def _done(t0):
    print(f"[analyze]   done in {time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)


def _guarded(ctx: Context, failures: list, name, step, *args):
    """Run one step; an input or fit error fails that analysis only (status, failures)."""
    t0 = _step(name)
    try:
        return step(ctx, *args)
    except DpdfitError as exc:
        ctx.results.status(name, "failed", str(exc))
        failures.append(f"{name}: {exc}")
        print(f"dpdfit: error: {exc}", file=sys.stderr)
        return None
    finally:
        _done(t0)


def _run_steps(ctx: Context, diagnosis: bool):
    """Every analysis in order, each handed what it needs -> (sweep, measured, failures)."""
    failures: list[str] = []

    def run(name, step, *args):
        return _guarded(ctx, failures, name, step, *args)

    fits = run("calibration", calibration_step)
    run("stability", stability_step, fits)
    sweep = run("sweep", sweep_step, fits)
    meas = run("spectra", spectra_step, sweep)
    run("traces", traces_step)
    run("gates", gates_step, sweep)
    run("propagation", propagation_step, fits)
    run("budget", budget_step)
    if diagnosis:
        run("diagnosis", diagnosis_step, fits)
    else:
        ctx.results.status("diagnosis", "skipped", "--no-diagnosis")
    return sweep, meas, failures


def _write(res: Results, out: Path, folder: Path, formula: str):
    """Publish every output, ``summary.json`` and ``summary.md`` together (staged)."""
    with staged_outputs() as stage:
        for name, obj in res.files.items():
            path = stage(out / name)
            if isinstance(obj, tuple):
                _, df, meta = obj
                text = "".join(f"# {k}: {json.dumps(to_jsonable(v))}\n" for k, v in meta.items())
                path.write_text(text + df.to_csv(index=False, float_format="%.10g"))
            else:
                path.write_text(obj)
        stage(out / "summary.json").write_text(json.dumps(to_jsonable(res.summary), indent=2) + "\n")
        stage(out / "summary.md").write_text(summary_markdown(res.summary, folder, formula))


def analyze(folder: str | os.PathLike, outdir: str | os.PathLike, *, formula: str = FORMULA,
            plots: bool = True, diagnosis: bool = True) -> dict:
    """Run every analysis on a campaign folder; write results into ``outdir``.

    Returns the summary dict (also written as ``summary.json``); its
    ``analyses`` entry says per analysis ``ok``, ``skipped`` (why) or
    ``failed`` (the error line).
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError("campaign folder not found", file=str(folder))
    out = Path(outdir)
    # one reader for every analysis, with the diagnosis's rules (dpdfit.recordings.campaign_folder)
    cf = CampaignFolder(folder)
    ctx = Context(campaign=cf, results=Results(), figdir=out / "figures", formula=formula,
                  figures=[] if plots else None)
    res = ctx.results
    res.summary["campaign"] = cf.meta.get("name", folder.name)
    res.summary["left_out"] = cf.left_out()
    sweep, meas, failures = _run_steps(ctx, diagnosis)
    res.summary["realism"] = realism_table(res.summary)
    res.summary["failures"] = failures
    out.mkdir(parents=True, exist_ok=True)
    t0 = _step("writing results")
    _write(res, out, folder, formula)
    if sweep is not None:
        ctx.figure(sweep_figures, sweep, meas)
    ctx.write_figures()
    _done(t0)
    return res.summary
