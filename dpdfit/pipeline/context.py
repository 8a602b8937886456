"""What every step of ``dpdfit analyze`` works with: the campaign, the results, the figures.

:class:`Results` collects the outputs in memory (files and each analysis's
status); :func:`dpdfit.pipeline.analyze.analyze` writes them
atomically at the end.  :class:`Context` is handed to every step: the
campaign folder (read once, :class:`~dpdfit.recordings.campaign_folder.CampaignFolder`),
the results, the fidelity formula and the queue of figures (drawn when the
results are saved and published together with them).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path

from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.report.figure_io import DPI

__all__ = ["Results", "Context", "draw_figure_jobs"]


class Results:
    """Collects outputs in memory; written atomically at the end.

    ``files`` maps a file name to its text, to ``("csv", DataFrame, meta)`` for a
    table (written with ``meta`` as ``# key: value`` header lines) or to
    ``("json", object)`` (rendered once, when written); ``statuses`` holds each
    analysis's status.  ``summary.json`` is rendered from the steps' results at the
    end (:func:`dpdfit.pipeline.analyze.render_summary`).
    """

    def __init__(self):
        self.files: dict[str, object] = {}
        self.statuses: dict = {}

    def text(self, name, text):
        """A text file ``name`` (e.g. ``summary.md``) with the content ``text``."""
        self.files[name] = text

    def json_file(self, name, obj):
        """A JSON file (indented, numpy values converted when written)."""
        self.files[name] = ("json", obj)

    def table(self, name, df, meta=None):
        """A CSV file ``name`` of the DataFrame ``df``, with ``meta`` written as
        ``# key: value`` header lines."""
        self.files[name] = ("csv", df, meta or {})

    def status(self, analysis, state, detail=""):
        """Record an analysis's status: ``state`` ``"ok"``, ``"skipped"`` or ``"failed"``,
        with a one-line ``detail``."""
        self.statuses[analysis] = {"status": state, "detail": detail}


@dataclass
class Context:
    """The state shared by the steps of one ``analyze`` run.

    ``figures`` is the queue of figure jobs, or None when figures are off:
    pairs ``(job, dpi)`` with ``job`` a zero-argument callable returning
    ``{file stem: Figure}``.
    """

    campaign: CampaignFolder
    results: Results
    formula: str
    figures: list | None = field(default_factory=list)

    @property
    def meta(self) -> dict:
        """``campaign.json`` with the defaults filled in."""
        return self.campaign.meta

    @property
    def folder(self) -> Path:
        """The campaign folder's path."""
        return self.campaign.path

    def figure(self, draw, *args, dpi: float = DPI, **kwargs) -> None:
        """Queue ``draw(*args, **kwargs)``, which returns ``{file stem: Figure}``, to be
        drawn at ``dpi`` when the results are saved (nothing when figures are off)."""
        if self.figures is not None:
            self.figures.append((functools.partial(draw, *args, **kwargs), dpi))


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
