"""What every step of ``dpdfit analyze`` works with: the campaign, the results, the figures.

:class:`Results` collects the outputs in memory (files, the summary, each
analysis's status); :func:`dpdfit.pipeline.analyze.analyze` writes them
atomically at the end.  :class:`Context` is handed to every step: the
campaign folder (read once, :class:`~dpdfit.recordings.campaign_folder.CampaignFolder`),
the results, the fidelity formula and the queue of figures (drawn when the
results are saved and published together with them).
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass, field
from pathlib import Path

from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.recordings.outputs import to_jsonable
from dpdfit.report.figure_io import DPI, save_figures

__all__ = ["Results", "Context", "write_figure_jobs", "draw_figure_jobs"]


class Results:
    """Collects outputs in memory; written atomically at the end.

    ``files`` maps a file name to its text, or to ``("csv", DataFrame, meta)``
    for a table (written with ``meta`` as ``# key: value`` header lines);
    ``summary`` becomes ``summary.json``.
    """

    def __init__(self):
        self.files: dict[str, object] = {}
        self.summary: dict = {"analyses": {}}

    def text(self, name, text):
        self.files[name] = text

    def json_file(self, name, obj):
        """A JSON file (indented, numpy values converted)."""
        self.files[name] = json.dumps(to_jsonable(obj), indent=2) + "\n"

    def table(self, name, df, meta=None):
        self.files[name] = ("csv", df, meta or {})

    def status(self, analysis, state, detail=""):
        self.summary["analyses"][analysis] = {"status": state, "detail": detail}


@dataclass
class Context:
    """The state shared by the steps of one ``analyze`` run.

    ``figures`` is the queue of figure jobs, or None when figures are off:
    pairs ``(job, dpi)`` with ``job`` a zero-argument callable returning
    ``{file stem: Figure}``.
    """

    campaign: CampaignFolder
    results: Results
    figdir: Path
    formula: str
    figures: list | None = field(default_factory=list)

    @property
    def meta(self) -> dict:
        """``campaign.json`` with the defaults filled in."""
        return self.campaign.meta

    @property
    def folder(self) -> Path:
        return self.campaign.path

    def figure(self, draw, *args, dpi: float = DPI, **kwargs) -> None:
        """Queue ``draw(*args, **kwargs)``, which returns ``{file stem: Figure}``, to be
        written at ``dpi`` into ``figdir`` (nothing when figures are off)."""
        if self.figures is not None:
            self.figures.append((functools.partial(draw, *args, **kwargs), dpi))

    def write_figures(self) -> list[str]:
        """Draw every queued figure, then write them all together as PNG into ``figdir``."""
        return write_figure_jobs(self.figures, self.figdir)


def draw_figure_jobs(jobs) -> dict:
    """Draw the figure jobs ``[(job, dpi)]`` (``job()`` -> ``{file stem: Figure}``):
    ``{file stem: (Figure, dpi)}``."""
    figures: dict = {}
    for job, res in jobs or ():
        for name, fig in job().items():
            if name in figures:
                raise ValueError(f"two figures named {name!r}")
            figures[name] = (fig, res)
    return figures


def write_figure_jobs(jobs, figdir) -> list[str]:
    """Draw the figure jobs ``[(job, dpi)]`` (``job()`` -> ``{file stem: Figure}``) and
    write them all together as PNG into ``figdir``; returns the paths."""
    figures = draw_figure_jobs(jobs)
    if not figures:
        return []
    return save_figures({k: f for k, (f, _) in figures.items()}, figdir,
                        dpi={k: d for k, (_, d) in figures.items()})
