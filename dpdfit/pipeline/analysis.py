"""What :func:`dpdfit.analyze` returns: every analysis's result and its tables, in memory.

:class:`Analysis` holds the outputs of one ``analyze`` run -- the summary,
each analysis's status, the tables as pandas DataFrames, the JSON outputs as
dicts and the result objects the steps made (calibration fits, alignment fit,
error budget, diagnosis) -- and writes them with :meth:`Analysis.save`,
exactly the files ``dpdfit analyze FOLDER -o RESULTS`` writes.
"""

from __future__ import annotations

import functools
import json
import logging
import time
from pathlib import Path

import pandas as pd

from dpdfit.core.jsonable import to_jsonable
from dpdfit.errors import InputError
from dpdfit.fits.alignment import AlignmentFit
from dpdfit.recordings.input_files import read_input_json
from dpdfit.recordings.outputs import check_output_folder, csv_table_text, staged_outputs
from dpdfit.report.figure_io import DPI
from dpdfit.report.summary import summary_markdown
from dpdfit.report.sweep_plots import sweep_figures

from .context import draw_figure_jobs

__all__ = ["Analysis", "write_outputs", "previous_outputs", "json_text"]

log = logging.getLogger(__name__)


def previous_outputs(out: Path) -> set[str]:
    """The files an earlier ``analyze`` wrote into ``out`` (``summary.json``'s ``outputs``).

    Only plain relative names inside ``out`` count; a folder without a dpdfit
    ``summary.json`` owns nothing (nothing of the user's is ever deleted).
    """
    try:
        # a regular file inside ``out``: a FIFO or a link out of it owns nothing, unread
        old = read_input_json(out / "summary.json", within=out, what="summary.json")
    except InputError:
        return set()
    if not isinstance(old, dict) or "analyses" not in old:
        return set()
    names = old.get("outputs", ())
    if not isinstance(names, (list, tuple)):
        return set()
    return {n for n in names if isinstance(n, str) and n and not Path(n).is_absolute()
            and ".." not in Path(n).parts}


def write_outputs(files: dict, summary: dict, out: Path, folder: Path, formula: str,
                  figures: dict | None = None) -> list[str]:
    """Publish every output, the figures (``{stem: (Figure, dpi)}`` -> ``figures/stem.png``),
    ``summary.json`` and ``summary.md`` together (one staging: all or nothing).

    ``files`` maps a name to text, ``("csv", DataFrame, meta)`` (a table with ``meta``
    as ``# key: value`` header lines) or ``("json", object)`` (rendered here, once).

    What the previous run into ``out`` wrote and this one does not is deleted in
    the same step; ``summary.json`` lists this run's ``outputs``.  Returns them.
    """
    figures = figures or {}
    owned = previous_outputs(out)
    names = sorted([*files, *(f"figures/{stem}.png" for stem in figures),
                    "summary.json", "summary.md"])
    summary = {**summary, "outputs": names}
    with staged_outputs() as stage:
        for name, obj in files.items():
            path = stage(out / name)
            if isinstance(obj, tuple) and obj[0] == "csv":
                _, df, meta = obj
                text = "".join(f"# {k}: {json.dumps(to_jsonable(v))}\n" for k, v in meta.items())
                path.write_text(text + csv_table_text(df, out / name, float_format="%.10g"))
            elif isinstance(obj, tuple):
                path.write_text(json_text(obj[1]))
            else:
                path.write_text(obj)
        for stem, (fig, dpi) in figures.items():
            fig.savefig(stage(out / "figures" / f"{stem}.png"), dpi=dpi, format="png")
        stage(out / "summary.json").write_text(json_text(summary))
        stage(out / "summary.md").write_text(summary_markdown(summary, folder, formula))
        for name in sorted(owned - set(names)):
            stage.remove(out / name)
    return names


def json_text(obj) -> str:
    """The text of a JSON output: indented, numpy values converted, newline-terminated."""
    return json.dumps(to_jsonable(obj), indent=2) + "\n"


class Analysis:
    """The results of :func:`dpdfit.analyze` on one campaign folder.

    Attributes
    ----------
    folder : Path
        The campaign folder.
    summary : dict
        What ``summary.json`` holds (``analyses``: per analysis ``status`` and
        ``detail``; ``failures``; each analysis's headline numbers).
    files : dict
        Output file name -> its text, ``("csv", DataFrame, meta)`` for a table or
        ``("json", object)`` for a JSON file.
    results : dict
        Analysis name -> the typed result its step returned (``calibration``:
        :class:`~dpdfit.pipeline.steps.CalibrationFits`, ``sweep``: a DataFrame,
        ``spectra``: :class:`~dpdfit.pipeline.steps.MeasuredSpectra`,
        ``gates``: :class:`~dpdfit.pipeline.steps.GateResults`, ``propagation``:
        :class:`~dpdfit.pipeline.steps.PropagationResults`, ``budget``:
        :class:`~dpdfit.analyses.budget.BudgetResult`,
        ``diagnosis``: :class:`~dpdfit.analyses.diagnosis.result.Diagnosis`); None when
        the analysis was skipped or failed.
    formula : str
    messages : list of str
        Warnings and errors logged while analysing.
    """

    def __init__(self, folder, summary: dict, files: dict, results: dict, formula: str, *,
                 figures=None, sweep=None, measured=None, messages=None):
        self.folder = Path(folder)
        self.summary = summary
        self.files = files
        self.results = results
        self.formula = formula
        self.messages = list(messages or [])
        self._figures = figures
        self._sweep, self._measured = sweep, measured

    def __repr__(self):
        st = {k: v["status"] for k, v in self.summary.get("analyses", {}).items()}
        return f"Analysis({str(self.folder)!r}, {st})"

    # ------------------------------------------------------------ tables and results
    @property
    def status(self) -> pd.DataFrame:
        """One row per analysis: ``status`` (ok, skipped, failed) and ``detail``."""
        return pd.DataFrame.from_dict(self.summary.get("analyses", {}), orient="index")

    @property
    def failures(self) -> list:
        """The analyses that failed, one ``"<analysis>: <error>"`` line each (empty: none)."""
        return list(self.summary.get("failures", []))

    @property
    def tables(self) -> dict:
        """Every CSV output as a DataFrame, by name without ``.csv`` (``calibration_runs``,
        ``sweep``, ``spectra_measured``, ``traces_check``, ``gate``, ``alignment_points``)."""
        return {name.removesuffix(".csv"): obj[1] for name, obj in self.files.items()
                if isinstance(obj, tuple) and obj[0] == "csv"}

    @functools.cached_property
    def outputs(self) -> dict:
        """Every JSON output as a dict, by name without ``.json`` (``calibration``,
        ``stability_amplitude``, ``propagation``, ``budget``, ``diagnosis``, ...), with
        numpy values as plain Python (what the file holds)."""
        return {name.removesuffix(".json"): to_jsonable(obj[1])
                for name, obj in self.files.items()
                if isinstance(obj, tuple) and obj[0] == "json"}

    def table(self, name: str) -> pd.DataFrame | None:
        """One table (``"sweep"`` or ``"sweep.csv"``), None when not produced."""
        return self.tables.get(name.removesuffix(".csv"))

    @property
    def calibration(self):
        """The :class:`~dpdfit.fits.calibration.Calibration` of the day (amplitude, phase)."""
        fits = self.results.get("calibration")
        return None if fits is None else fits.calibration

    @property
    def calibration_runs(self) -> pd.DataFrame | None:
        """The per-run fits of the calibration runs (``calibration_runs.csv``), None when
        not produced."""
        return self.table("calibration_runs")

    @property
    def sweep(self) -> pd.DataFrame | None:
        """The simulated amplitude sweep of the calibration (``sweep.csv``), None when not
        produced."""
        return self.table("sweep")

    @property
    def gate(self) -> pd.DataFrame | None:
        """The gate table: fidelities per setting, joined with the gate rates."""
        return self.table("gate")

    @property
    def alignment_points(self) -> pd.DataFrame | None:
        """The alignment fit's points (``alignment_points.csv``: inputs, ``r_rel``,
        ``F_PD``, ``eta_bar``, residuals), None when not produced."""
        return self.table("alignment_points")

    @property
    def alignment(self) -> AlignmentFit | None:
        """The alignment fit of ``alpha`` and ``delta`` (with its points)."""
        gates = self.results.get("gates")
        return None if gates is None else gates.alignment

    @property
    def budget(self) -> pd.DataFrame | None:
        """The error budget (Table S2): one row per term, ``estimate`` and ``error``."""
        b = self.results.get("budget")
        if b is None:
            return None
        d = b.to_dict()
        rows = {k: v for k, v in d.items() if isinstance(v, dict) and "estimate" in v}
        return pd.DataFrame.from_dict(rows, orient="index")[["estimate", "error"]]

    @property
    def diagnosis(self):
        """The :class:`~dpdfit.analyses.diagnosis.result.Diagnosis` (None when not run)."""
        return self.results.get("diagnosis")

    # ------------------------------------------------------------ writing
    def draw_figures(self) -> dict:
        """Draw every figure of this analysis: ``{file stem: (Figure, dpi)}`` (none when
        made with ``plots=False``)."""
        if self._figures is None:
            return {}
        jobs = list(self._figures)
        if self._sweep is not None:
            jobs.append((functools.partial(sweep_figures, self._sweep, self._measured), DPI))
        return draw_figure_jobs(jobs)

    def save(self, outdir, *, plots: bool = True) -> Path:
        """Write every output into ``outdir`` -- the files ``dpdfit analyze -o`` writes:
        tables, JSON files, ``summary.json``, ``summary.md`` and, when figures were made
        (``analyze(plots=True)``) and ``plots``, ``figures/*.png`` -- staged and published
        together.  What an earlier run wrote into ``outdir`` and this one does not (e.g.
        ``gate.csv`` when the gates were skipped this time) is deleted in the same step;
        other files are left alone.  Interrupted (Ctrl-C) or failed, it leaves ``outdir``
        as it was."""
        out = Path(outdir)
        check_output_folder(out, "results folder")
        t0 = time.perf_counter()
        log.info("[analyze] writing results ...")
        figures = self.draw_figures() if plots else {}
        write_outputs(self.files, self.summary, out, self.folder, self.formula, figures)
        log.info(f"[analyze]   done in {time.perf_counter() - t0:.1f} s")
        return out
