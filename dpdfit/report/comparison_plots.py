"""The evidence of each hypothesis before and after further recordings
(``dpdfit diagnose --compare --plot``): :func:`comparison_figure` draws a
:class:`~dpdfit.analyses.diagnosis.comparison.Comparison` and returns the Figure.
"""

from __future__ import annotations

from dpdfit.analyses.diagnosis.comparison import Comparison
from dpdfit.analyses.diagnosis.verdict import BIC_DECISIVE
from dpdfit.report.figure_io import single_axes

__all__ = ["comparison_figure", "COMPARISON_ROWS"]

#: effects drawn at most, the best (before or after) first
COMPARISON_ROWS = 12

_ROLE = {"named": "named", "alternative": "alt.", None: "-"}
#: the after bar's colour by the effect's role then
_COLOUR = {"named": "C3", "alternative": "C1", None: "C0"}


def _rows(comparison: Comparison) -> list:
    rows = [r for r in comparison.evidence
            if r.get("gap_before") is not None or r.get("gap_after") is not None]

    def best(r):
        return min(v for v in (r.get("gap_before"), r.get("gap_after")) if v is not None)
    return sorted(rows, key=best)[:COMPARISON_ROWS]


def _label(r: dict) -> str:
    before, after = r.get("role_before"), r.get("role_after")
    if before is None and after is None:
        return r["effect"]
    if before == after:
        return f"{r['effect']} ({_ROLE[after]})"
    return f"{r['effect']} ({_ROLE[before]} -> {_ROLE[after]})"


def comparison_figure(comparison: Comparison, *, ax=None):
    """Paired horizontal bars, one pair per single effect: its evidence (its family's
    tempered delta BIC against the baseline, as the diagnosis ranks them) relative to the
    best effect's, before (grey) and after (coloured: red named, orange an alternative,
    blue neither) the further recordings; a symmetric-log axis, the decisive gap dashed.
    The labels say each effect's role before -> after.

    Drawn into ``ax`` when given; returns the Figure.
    """
    from matplotlib.patches import Patch
    rows = _rows(comparison)
    fig, ax = single_axes(ax, (6.4, 1.6 + 0.42 * max(len(rows), 1)))
    for i, r in enumerate(rows):
        y = len(rows) - 1 - i
        for dy, key in ((0.2, "before"), (-0.2, "after")):
            gap, role = r.get(f"gap_{key}"), r.get(f"role_{key}")
            if gap is None:
                continue
            c = _COLOUR[role] if key == "after" else "0.7"
            ax.barh(y + dy, gap, height=0.38, color=c, edgecolor="k" if role == "named" else c)
            # a zero gap (the best) stays visible, drawn over the axis
            ax.plot([gap], [y + dy], "|", color="k", ms=8, mew=2, clip_on=False)
    if not rows:
        ax.text(0.5, 0.5, "no ranked effects to compare", ha="center", va="center",
                transform=ax.transAxes)
    ax.set_yticks(range(len(rows)), [_label(r) for r in reversed(rows)], fontsize=7)
    ax.axvline(BIC_DECISIVE, color="k", ls="--", lw=0.8)
    ax.set_xscale("symlog", linthresh=BIC_DECISIVE)
    ax.set_xlim(left=0)
    ax.set_xlabel("evidence gap to the best effect (family delta BIC, tempered; dashed: "
                  "decisive)", fontsize=8)
    ax.tick_params(axis="x", labelsize=7)
    ax.legend([Patch(color="0.7"), *(Patch(facecolor=c, edgecolor="k" if k == "named" else c)
                                     for k, c in _COLOUR.items())],
              ["before", "after: named", "after: alternative", "after: other"],
              fontsize=7, loc="best")
    ax.set_title(f"evidence before and after: {comparison.verdict_before} -> "
                 f"{comparison.verdict_after}", fontsize=9)
    return fig
