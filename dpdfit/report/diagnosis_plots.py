"""Before/after residual figures of the discrepancy diagnosis (``dpdfit diagnose --plot``).

:func:`diagnosis_figure` draws one observable group and returns the Figure;
:func:`diagnosis_figures` draws every group there is (written at
:data:`DIAGNOSIS_DPI`).
"""

from __future__ import annotations

from dpdfit.analyses.diagnosis.result import Diagnosis
from dpdfit.report.figure_io import panel_grid

__all__ = ["diagnosis_figure", "diagnosis_figures", "DIAGNOSIS_DPI",
           "DIAGNOSIS_GROUPS"]

#: resolution of the diagnosis figures
DIAGNOSIS_DPI = 110

#: observable group -> test on an observable's name
DIAGNOSIS_GROUPS = {
    "tones": lambda obs: obs in ("R10", "R23", "R5lo", "R5hi", "gate_balance", "red_blue",
                                 "gate_power"),
    "gates": lambda obs: obs in ("F_pop", "imb", "C", "P00_t", "P11_t"),
    "calibration": lambda obs: obs.startswith("calibration"),
}


def _series(result: Diagnosis, group: str) -> list:
    """Keys ``(observable, sideband, dpd)`` of the baseline series in ``group``."""
    if group not in DIAGNOSIS_GROUPS:
        raise ValueError(f"unknown diagnosis group {group!r}; choose from {list(DIAGNOSIS_GROUPS)}")
    return list(dict.fromkeys((s[0], s[1], s[2]) for s in result.series_before
                              if DIAGNOSIS_GROUPS[group](s[0])))


def _residual_panel(ax, result: Diagnosis, before, after, k):
    """One series: baseline residuals (grey), residuals under the chosen effect, mismatches."""
    _, sb, d, xname, x, z = before
    ax.axhline(0, color="k", lw=0.5)
    ax.plot(x, z, "o", ms=3, color="0.6", label="baseline")
    if after is not None and result.chosen is not None:
        ax.plot(after[4], after[5], "o", ms=3, color="C3", label=result.chosen.effect)
    for m in result.mismatches:
        if (m["observable"], m["sideband"], -1 if m["dpd"] is None else m["dpd"]) == k:
            ax.axvspan(*m["range"], color="C1", alpha=0.2)
    ax.set_title(f"{k[0]} {sb} " + ("" if d < 0 else f"dpd={d}"), fontsize=8)
    ax.set_xlabel(xname, fontsize=7)
    ax.set_ylabel("z", fontsize=7)
    ax.tick_params(labelsize=6)


def diagnosis_figure(result: Diagnosis, group: str = "tones", *, fig=None):
    """Standardised residuals of one observable group (``"tones"``, ``"gates"``,
    ``"calibration"``), before and after the chosen effect.

    Baseline residuals are grey, residuals under the chosen effect coloured,
    the located mismatch intervals shaded.  Drawn into ``fig`` (an empty Figure
    or SubFigure) when given; returns the Figure.  Raises ``ValueError`` when
    the diagnosis has no series of that group.
    """
    keys = _series(result, group)
    if not keys:
        raise ValueError(f"the diagnosis has no {group} series")
    before = {(s[0], s[1], s[2]): s for s in result.series_before}
    after = {(s[0], s[1], s[2]): s for s in result.series_after}
    n = len(keys)
    cols = 4 if n > 4 else n
    rows = -(-n // cols)
    own = fig is None
    fig, axes = panel_grid(fig, rows, cols, (3.2 * cols, 2.4 * rows), layout=None)
    for ax, k in zip(axes.flat, keys):
        _residual_panel(ax, result, before[k], after.get(k), k)
    for ax in list(axes.flat)[n:]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=6)
    axes.flat[0].figure.suptitle(  # the caller's SubFigure, if that is where the axes are
        f"standardised residuals: baseline vs {result.verdict}", fontsize=9)
    if own:  # the caller's figure keeps its own layout
        fig.tight_layout()
    return fig


def diagnosis_figures(result: Diagnosis) -> dict:
    """``{file stem: Figure}``: ``diagnosis_tones``, ``diagnosis_gates``,
    ``diagnosis_calibration`` (each when the diagnosis has series of that group)."""
    return {f"diagnosis_{g}": diagnosis_figure(result, g)
            for g in DIAGNOSIS_GROUPS if _series(result, g)}
