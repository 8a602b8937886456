"""Corner plot of the amplitude-calibration posterior (:mod:`dpdfit.fits.posterior`), drawn
with the ``corner`` package.

:func:`corner_figure` returns the Figure, written by ``dpdfit analyze`` at
:data:`CORNER_DPI`.
"""

from __future__ import annotations

import numpy as np

from dpdfit.errors import InputError
from dpdfit.fits.posterior import PosteriorResult
from dpdfit.report.figure_io import new_figure, root_figure

__all__ = ["corner_figure", "CORNER_DPI"]

#: resolution of the corner plot
CORNER_DPI = 110


def _columns(result: PosteriorResult) -> dict:
    """``{name: draws}`` of ``A_corr`` and every ``a_k`` with k > 1."""
    cols = {"A_corr": np.asarray(result.A_corr_draws)}
    for i, p in enumerate(result.powers):
        if p > 1:
            cols[f"a{p}"] = np.asarray(result.a_draws)[:, i]
    return cols


def _label(name: str) -> str:
    return "$A_{corr}$" if name == "A_corr" else f"$a_{{{name[1:]}}}$"


def corner_figure(result: PosteriorResult, params=None, *, bins: int = 40, fig=None,
                  **corner_kwargs):
    """Corner plot of ``A_corr`` and selected ``a_k`` (:func:`corner.corner`).

    ``params`` lists names among ``"A_corr"`` and ``"a2".."aK"`` (default:
    ``A_corr`` and the next three coefficients).  Diagonal: histograms with the
    median and 68 % interval (dashed); below it: the 2-d densities of the
    draws.  The autocorrelation time and the number of independent draws are
    written in the empty upper-right corner.  Drawn into ``fig`` (an empty
    Figure or SubFigure) when given; further keywords go to :func:`corner.corner`.
    Returns the Figure.
    """
    import corner  # with matplotlib: only when a corner plot is drawn

    cols = _columns(result)
    params = list(params or ["A_corr"] + [f"a{p}" for p in result.powers[1:4]])
    for p in params:
        if p not in cols:
            raise InputError(f"unknown corner-plot parameter {p!r}; choose from {list(cols)}")
    X = np.column_stack([cols[p] for p in params])
    k = len(params)
    if fig is None:  # corner's own panel size: 2 in per panel, margins 1.4 in
        fig = new_figure((2.0 * k + 0.1 * (k - 1) + 1.4,) * 2, layout=None)
    options = dict(labels=[_label(p) for p in params], bins=bins, quantiles=[0.16, 0.5, 0.84],
                   max_n_ticks=3, use_math_text=True)
    corner.corner(X, fig=fig, **{**options, **corner_kwargs})
    note = (f"posterior: {X.shape[0]} draws\nautocorrelation time {result.tau_max:.1f}\n"
            f"{result.n_independent:.0f} independent")
    if k > 1:
        fig.text(0.97, 0.97, note, ha="right", va="top", fontsize=9)
    else:
        fig.suptitle(note.replace("\n", ", "), fontsize=8)
    return root_figure(fig)
