"""`dpdfit analyze`: every analysis dpdfit has, run on a campaign folder.

Each analysis reads only the files it needs; a missing file skips that
analysis (with the reason in the summary), a malformed file stops that
analysis with the one-line error naming file, column and row, and the others
go on.  A value no real campaign holds (a unit slip:
:mod:`dpdfit.recordings.plausibility`) refuses the whole campaign before any
analysis runs, and nothing is written; so does a file of the folder that leads out
of it, is not a regular file or is beyond the size bound, or is not a table a lab
writes (:class:`~dpdfit.errors.RefusedFileError`, :mod:`dpdfit.recordings.campaign_folder`).  The results folder is checked before any work; all outputs, figures
included, are staged and published together at the end (Ctrl-C leaves a
previous results folder exactly as it was), and what a previous run wrote
there and this one does not is deleted in the same step.

Analyses, in the order of :data:`dpdfit.pipeline.steps.PIPELINE` (stated
there once):

* ``calibration`` -- the amplitude run the day's predistortion table came
  from (``campaign.json``), the phase run used for the model; every
  amplitude and phase run for the per-run table.  -> ``calibration.json``,
  ``calibration_runs.csv``, Fig. 1.
* ``stability`` -- y(1) and phi(1) per run: mean, sd, drift test, Allan
  deviation, curve envelopes (S2). -> ``stability_*.json``, Figs. S1, S2.
* ``sweep`` -- the simulated amplitude sweep from that calibration at the
  spectra's ``nu``, ``xi0`` (S6). -> ``sweep.csv``, Figs. 2, 5, S3, S5.
* ``spectra`` -- measured tone powers (``spectra.csv``): ``R10``, ``R23``,
  ``dP_n``, ``F_est`` per A and flag, ``eta_bar`` from the simulation's
  spline (S6.6), measured threshold efficiencies
  (:mod:`dpdfit.analyses.measured_spectra`). -> ``spectra_measured.csv``,
  Figs. 2/S6/5 with measured (solid) and simulated (dashed) curves.
* ``traces`` -- the bundled raw traces re-analysed and checked against
  ``spectra.csv``. -> ``traces_check.csv``.
* ``gates`` -- count inference (S7): population and parity fidelities per
  setting pooled over scans (``gate.csv``, joined with ``gate_rates.csv``),
  the alignment fit of ``alpha`` and ``delta`` against the simulated sweep
  (``alignment_points.csv``), Figs. 3, 4, S6, S7.
* ``propagation`` -- emcee posterior of the day's amplitude calibration with
  the run-to-run drift model, 10^4 draws pushed through the sweep at
  A = 0.5 for a fresh and a 30-day-old table. -> ``propagation.json``.
* ``budget`` -- the error budget of Table S2 (S10) from ``budget.toml`` in
  the campaign folder (or the paper's inputs), with the gate times from
  ``gate_rates.csv`` and ``delta`` from the alignment fit. -> ``budget.json``.
* ``diagnosis`` -- the discrepancy diagnosis (unless ``diagnosis=False``).
  -> ``diagnosis.json``.

One pipeline: each step (:mod:`dpdfit.pipeline.steps`) gets what earlier
steps produced instead of recomputing it -- every recording file is read once
(:class:`~dpdfit.recordings.campaign_folder.CampaignFolder`, shared by every
step, the diagnosis included), every calibration run is fitted once (in
``calibration``; ``stability``, ``propagation`` and the diagnosis reuse the
fits) and the amplitude posterior is sampled once (``propagation``: the
propagation, the threshold distributions and the corner plot share it).  The
Markdown summary is written by :mod:`dpdfit.report.summary`.

In a notebook: ``res = dpdfit.analyze(folder)`` (no output folder: nothing is
written) returns an :class:`~dpdfit.pipeline.analysis.Analysis` -- the tables as
DataFrames (``res.tables``, ``res.sweep``, ``res.gate``, ``res.budget``), the
fits (``res.calibration``, ``res.alignment``), each analysis's status
(``res.status``) -- and ``res.save(outdir)`` writes what the command line
writes.  Messages go through :mod:`logging` (logger ``dpdfit.pipeline.analyze``:
one INFO line per step, ERROR for a failed analysis); a progress bar over the
steps is shown when stderr is a terminal (``progress=None``), or as
``progress`` says.
"""

from __future__ import annotations

import logging
import os
import time
from pathlib import Path

from dpdfit.core.defaults import FORMULA
from dpdfit.core.progress import progress_bar, progress_scope
from dpdfit.errors import DpdfitError, InputError
from dpdfit.recordings.campaign_folder import CampaignFolder, check_campaign_folder
from dpdfit.recordings.outputs import check_output_folder
from dpdfit.report.summary import realism_table

from .analysis import Analysis
from .context import Context, Results
from .steps import PIPELINE

__all__ = ["analyze", "Analysis", "STEPS", "render_summary"]

log = logging.getLogger(__name__)

#: The analyses' names in the order they run (:data:`~dpdfit.pipeline.steps.PIPELINE`).
STEPS = tuple(step.name for step in PIPELINE)


def _guarded(ctx: Context, failures: list, name, step, *args):
    """Run one step; an input or fit error fails that analysis only (status, failures)."""
    log.info(f"[analyze] {name} ...")
    t0 = time.perf_counter()
    try:
        return step(ctx, *args)
    except DpdfitError as exc:
        ctx.results.status(name, "failed", str(exc))
        failures.append(f"{name}: {exc}")
        log.error("%s", exc)
        return None
    finally:
        log.info(f"[analyze]   done in {time.perf_counter() - t0:.1f} s")


def _run_steps(ctx: Context, diagnosis: bool, bar) -> tuple[dict, list]:
    """Every analysis of the pipeline in order, each handed the earlier results it needs
    -> (step results, failures)."""
    failures: list[str] = []
    out: dict = {}
    for step in PIPELINE:
        bar.set_postfix_str(step.name, refresh=False)
        if step.name == "diagnosis" and not diagnosis:
            ctx.results.status("diagnosis", "skipped", "--no-diagnosis")
            out[step.name] = None
        else:
            out[step.name] = _guarded(ctx, failures, step.name, step.run,
                                      *(out.get(n) for n in step.needs))
        bar.update()
    return out, failures


class _Collect(logging.Handler):
    """Keeps the warnings and errors logged during one ``analyze`` (``Analysis.messages``)."""

    def __init__(self):
        super().__init__(logging.WARNING)
        self.messages: list[str] = []

    def emit(self, record):
        self.messages.append(record.getMessage())


def _analysis(folder: Path, formula, plots, diagnosis, bar) -> Analysis:
    """Run the steps; everything in memory (figures queued, drawn by ``Analysis.save``)."""
    cf = CampaignFolder(folder)
    cf.check_plausible()           # a unit slip refuses the campaign before any analysis
    ctx = Context(campaign=cf, results=Results(), formula=formula,
                  figures=[] if plots else None)
    res = ctx.results
    collect = _Collect()
    logging.getLogger("dpdfit").addHandler(collect)
    try:
        results, failures = _run_steps(ctx, diagnosis, bar)
    finally:
        logging.getLogger("dpdfit").removeHandler(collect)
    summary = render_summary(cf, res.statuses, results, failures)
    spectra, sweep = results.get("spectra"), results.get("sweep")
    return Analysis(folder, summary, res.files, results, formula, figures=ctx.figures,
                    sweep=None if sweep is None else sweep.table,
                    measured=None if spectra is None else spectra.table,
                    messages=collect.messages)


def render_summary(cf: CampaignFolder, statuses: dict, results: dict, failures: list) -> dict:
    """``summary.json`` of one run, made once from the steps' typed results: each
    analysis's status, the campaign, what was left out, each step's section (from its
    result, :data:`~dpdfit.pipeline.steps.PIPELINE`), the realism table, the failures."""
    summary = {"analyses": statuses, "campaign": cf.meta.get("name", cf.path.name),
               "left_out": cf.left_out()}
    for step in PIPELINE:
        result = results.get(step.name)
        ok = statuses.get(step.name, {}).get("status") == "ok"
        if result is not None and ok and step.summary is not None:
            summary[step.name] = step.summary(result)
    summary["realism"] = realism_table(summary, results.get("gates") if "gates" in summary
                                       else None)
    summary["failures"] = failures
    return summary


def analyze(folder: str | os.PathLike, outdir: str | os.PathLike | None = None, *,
            formula: str = FORMULA, plots: bool = True, diagnosis: bool = True,
            progress: bool | None = None) -> Analysis:
    """Run every analysis on a campaign folder; with ``outdir``, write the results there.

    Parameters
    ----------
    folder : path-like
        The campaign folder.
    outdir : path-like, optional
        Results folder, written as by ``dpdfit analyze FOLDER -o OUTDIR``.
        Without it nothing is written (``Analysis.save`` writes later).
    formula : {"exact", "paper"}
        Bell-fidelity expression for ``F_est``.
    plots : bool
        Make the figures (drawn when the results are saved).
    diagnosis : bool
        Run the discrepancy diagnosis (the slowest analysis).
    progress : bool, optional
        A progress bar over the analyses (and the long work inside them);
        default: when stderr is a terminal.  ``False``: nothing on the terminal.

    Returns
    -------
    Analysis
        Every analysis's typed result and tables, and the summary
        (``res.summary["analyses"]``: per analysis ``ok``, ``skipped`` (why) or
        ``failed`` (the error line); ``res.status`` as a table).
    """
    folder = check_campaign_folder(folder)
    if outdir is not None:  # checked before any work, not after minutes of it
        check_output_folder(outdir, "results folder")
        if Path(outdir).resolve() == folder.resolve():
            raise InputError("results folder must differ from the campaign folder",
                             file=str(outdir))
        check_output_folder(Path(outdir) / "figures", "figures folder")
    n = len(STEPS) + (outdir is not None)
    with progress_scope(progress), progress_bar(total=n, desc="analyze") as bar:
        result = _analysis(folder, formula, plots, diagnosis, bar)
        if outdir is not None:
            bar.set_postfix_str("writing", refresh=False)
            result.save(outdir)
            bar.update()
    return result
