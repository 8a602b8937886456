"""Figures S2 (calibration stability over time) and S3 (response envelope of all runs).

:func:`stability_figure` (S2) and :func:`envelope_figure` (S3) each return a
Figure; :func:`stability_figures` draws both as ``dpdfit analyze`` writes them
(:func:`~dpdfit.report.figure_io.save_figures` writes any of them as PNG).
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.stability import StabilityResult
from dpdfit.report.figure_io import single_axes

__all__ = ["stability_figure", "envelope_figure", "stability_figures"]

_FIGSIZE = (5.2, 3.6)


def _color(kind: str) -> str:
    return "C0" if kind == "amplitude" else "purple"


def stability_figure(result: StabilityResult, *, ax=None):
    """Fig. S1: per-run values with error bars versus time, the mean (dashed), the
    +/- 1 sigma band and the fitted trend line.

    Drawn into ``ax`` when given; returns the Figure.
    """
    r = result
    fig, ax = single_axes(ax, _FIGSIZE)
    color = _color(r.kind)
    hours = r.span_days < 1
    scale = 24.0 if hours else 1.0
    ax.axhspan(r.mean - r.std, r.mean + r.std, color=color, alpha=0.18,
               label=f"$\\pm1\\sigma$ ({r.std:.4g})")
    ax.axhline(r.mean, color=color, ls="--", lw=1.2, label=f"mean ({r.mean:.4f})")
    ax.errorbar(r.days * scale, r.values, yerr=r.stderrs, fmt="o", color="k", ms=3.5, lw=1,
                label=f"runs (n = {r.n_runs})")
    d = r.drift
    if np.isfinite(d.get("trend_per_day", np.nan)):
        tt = np.linspace(0, r.span_days, 50)
        ax.plot(tt * scale, d["intercept"] + d["trend_per_day"] * tt, color="C3", lw=1,
                label=f"trend {d['trend_per_day'] * (1 / scale):+.2e}/"
                      f"{'h' if hours else 'day'} (p = {d['trend_p_value']:.2g})")
    ax.set_xlabel("time since first run [" + ("h" if hours else "days") + "]")
    ax.set_ylabel("$y(1) = A_{corr}$" if r.kind == "amplitude" else "$\\phi(1)$ [rad]")
    ax.set_title(f"Fig. S1: {r.kind} calibration stability", fontsize=10)
    ax.legend(fontsize=7)
    return fig


def envelope_figure(result: StabilityResult, *, ax=None):
    """Fig. S2: every run's response curve, the mean curve and the +/- 1 sigma envelope.

    Drawn into ``ax`` when given; returns the Figure.
    """
    r = result
    fig, ax = single_axes(ax, _FIGSIZE)
    color = _color(r.kind)
    for c in r.curves:
        ax.plot(r.grid, c, color="0.6", lw=0.5, alpha=0.6)
    ax.fill_between(r.grid, r.mean_curve - r.std_curve, r.mean_curve + r.std_curve,
                    color=color, alpha=0.3, label="$\\pm1\\sigma$")
    ax.plot(r.grid, r.mean_curve, color=color, lw=1.6, label=f"mean of {r.n_runs} runs")
    ax.set_xlabel("RF amplitude $A$")
    ax.set_ylabel("$y(A)$" if r.kind == "amplitude" else "$\\phi(A)$ [rad]")
    ax.set_title(f"Fig. S2: {r.kind} response envelope", fontsize=10)
    ax.legend(fontsize=7)
    return fig


def stability_figures(result: StabilityResult) -> dict:
    """Figs. S1 and S2 as ``dpdfit analyze`` writes them: ``{file stem: Figure}``
    (``figS1_stability_<kind>``, ``figS2_envelope_<kind>``)."""
    return {f"figS1_stability_{result.kind}": stability_figure(result),
            f"figS2_envelope_{result.kind}": envelope_figure(result)}
