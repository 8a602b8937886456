"""Figure making and PNG writing shared by every figure module of ``dpdfit.report``.

matplotlib is imported on first use only (``dpdfit`` itself never needs it) and
the library never chooses a backend: new figures are plain
:class:`matplotlib.figure.Figure` objects, not managed by pyplot (nothing to
close; in Jupyter a returned Figure is shown by the inline support, whatever
backend the notebook uses).  Every drawing function takes ``ax=`` (one panel)
or ``fig=`` (several panels) to draw into the caller's own axes or figure instead.

Saving is a separate step: :func:`save_figures` writes a set of figures as PNG
(130 dpi unless told) into a staging area
(:func:`dpdfit.recordings.outputs.staged_outputs`) so that the set appears
together or not at all.  :func:`use_noninteractive_backend` is for the command
line only (``dpdfit.cli`` may not import matplotlib itself).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import TYPE_CHECKING

from dpdfit.recordings.outputs import staged_outputs

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

__all__ = ["DPI", "new_figure", "single_axes", "panel_grid", "root_figure", "save_figures",
           "use_noninteractive_backend"]

#: resolution of every PNG figure (unless a module says otherwise)
DPI = 130


def new_figure(figsize, layout: str | None = "constrained") -> Figure:
    """A new :class:`~matplotlib.figure.Figure` of ``figsize`` inches, not managed by pyplot."""
    from matplotlib.figure import Figure
    return Figure(figsize=figsize, layout=layout)


def root_figure(artist) -> Figure:
    """The top-level :class:`~matplotlib.figure.Figure` of an Axes, SubFigure or Figure."""
    fig = artist.figure
    while fig.figure is not fig:
        fig = fig.figure
    return fig


def single_axes(ax, figsize):
    """``(figure, ax)``: the caller's axes, or one axes on a new figure of ``figsize``."""
    if ax is not None:
        return root_figure(ax), ax
    fig = new_figure(figsize)
    return fig, fig.add_subplot()


def panel_grid(fig, nrows: int, ncols: int, figsize, layout: str | None = "constrained"):
    """``(figure, axes)`` with ``axes`` an ``nrows x ncols`` array of new axes.

    The axes go into ``fig`` (the caller's empty Figure or SubFigure) or, when
    ``fig`` is None, into a new figure of ``figsize``; the top-level Figure is returned.
    """
    if fig is None:
        fig = new_figure(figsize, layout)
    axes = fig.subplots(nrows, ncols, squeeze=False)
    return root_figure(fig), axes


def save_figures(figures: Mapping[str, Figure], outdir: str | os.PathLike, *,
                 dpi: float | Mapping[str, float] = DPI) -> list[str]:
    """Write ``{name: Figure}`` as ``outdir/<name>.png``, all together or none; returns the paths.

    ``dpi`` is one resolution for all, or ``{name: dpi}`` (names not in it get
    :data:`DPI`).  The files are staged and moved into place once every figure
    was written (:func:`dpdfit.recordings.outputs.staged_outputs`).
    """
    written = []
    os.makedirs(outdir, exist_ok=True)
    with staged_outputs() as stage:
        for name, fig in figures.items():
            res = dpi.get(name, DPI) if isinstance(dpi, Mapping) else dpi
            path = os.path.join(outdir, f"{name}.png")
            fig.savefig(stage(path), dpi=res, format="png")
            written.append(path)
    return written


def use_noninteractive_backend() -> None:
    """Select matplotlib's Agg backend: for the ``dpdfit`` command line only, before it plots.

    The library never calls this (a notebook keeps its inline figures).
    """
    import matplotlib
    matplotlib.use("Agg")
