"""The evidence of each hypothesis before and after further recordings
(``dpdfit diagnose --compare --plot``): :func:`comparison_figure` draws a
:class:`~dpdfit.analyses.diagnosis.comparison.compare.Comparison` and returns the Figure.
"""

from __future__ import annotations

from dpdfit.analyses.diagnosis.comparison.compare import Comparison
from dpdfit.analyses.diagnosis.evidence.thresholds import BIC_DECISIVE
from dpdfit.report.figure_io import new_figure, root_figure

__all__ = ["comparison_figure", "pair_panel", "COMPARISON_ROWS"]

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


def pair_panel(comparison: Comparison, ax) -> None:
    """The pair of hypotheses the recording was to separate (the earlier proposal's
    ``binding`` pair, A its ``truth`` and B its ``rival``): their chi2 gap
    ``chi2(B) - chi2(A)`` on the recordings before and after (bars; > 0 favours A), the
    gap expected after were A or B the true one (markers: the gap before plus or minus
    the separation predicted for it), the decisive gaps dashed.  Says so in the panel
    when there is no pair to draw (the separation's ``reason``)."""
    s = comparison.separation or {}
    before, after = s.get("chi2_before"), s.get("chi2_after")
    ax.set_yticks([])
    if not before or not after:
        ax.text(0.5, 0.5, f"no pair to compare: {s.get('reason') or 'no proposal'}",
                ha="center", va="center", transform=ax.transAxes, fontsize=7, wrap=True)
        return
    g0 = float(before["rival"]) - float(before["truth"])
    g1 = float(after["rival"]) - float(after["truth"])
    ax.barh([1, 0], [g0, g1], height=0.6, color=["0.7", "C3"])
    for val, key, mark in ((s.get("predicted_if_truth"), "A", "v"),
                           (s.get("predicted_if_rival"), "B", "^")):
        if val is not None:
            x = g0 + float(val) if key == "A" else g0 - float(val)
            ax.plot([x], [0], mark, color="k", ms=7, label=f"expected after, were {key} true")
    for x in (BIC_DECISIVE, -BIC_DECISIVE):
        ax.axvline(x, color="k", ls="--", lw=0.8)
    ax.axvline(0, color="k", lw=0.6)
    ax.set_yticks([1, 0], ["before", "after"], fontsize=7)
    ax.set_xscale("symlog", linthresh=BIC_DECISIVE)
    ax.set_xlabel(f"chi2(B) - chi2(A) (> 0 favours A; dashed: decisive)\n"
                  f"A = {s.get('truth')}, B = {s.get('rival')}", fontsize=7)
    ax.tick_params(axis="x", labelsize=7)
    ax.legend(fontsize=6, loc="best")
    ax.set_title(f"(a) the pair the {str(s.get('what') or 'recording').replace('_', ' ')} "
                 "was to separate", fontsize=9)


def comparison_figure(comparison: Comparison, *, ax=None):
    """Two panels: (a) :func:`pair_panel`, the pair the recording was to separate; (b)
    paired horizontal bars, one pair per single effect: its evidence (its family's
    tempered delta BIC against the baseline, as the diagnosis ranks them) relative to the
    best effect's, before (grey) and after (coloured: red named, orange an alternative,
    blue neither) the further recordings; a symmetric-log axis, the decisive gap dashed.
    The labels say each effect's role before -> after.

    With ``ax``, panel (b) alone is drawn into it; returns the Figure.
    """
    from matplotlib.patches import Patch
    rows = _rows(comparison)
    height = 1.6 + 0.42 * max(len(rows), 1)
    if ax is None:
        fig = new_figure((6.4, height + 1.9))
        top, ax = fig.subplots(2, 1, gridspec_kw={"height_ratios": [1.9, height]})
        pair_panel(comparison, top)
    else:
        fig = root_figure(ax)
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
    ax.set_title(f"(b) evidence of each effect before and after: "
                 f"{comparison.verdict_before} -> {comparison.verdict_after}", fontsize=9)
    return fig
