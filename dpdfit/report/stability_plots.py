"""Figures S2 (calibration stability over time) and S3 (response envelope of all runs)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from dpdfit.analyses.stability import StabilityResult
from dpdfit.recordings.outputs import staged_outputs
from dpdfit.report.plots import _pyplot

__all__ = ["plot_stability"]


def plot_stability(result: StabilityResult, outdir: str | os.PathLike) -> list[str]:
    """Write ``figS2_stability_<kind>.png`` and ``figS3_envelope_<kind>.png``.

    Fig. S2: per-run values with error bars versus time, mean (dashed),
    +/- 1 sigma band, fitted trend line.  Fig. S3: all runs' curves, the mean
    curve and the +/- 1 sigma envelope.  Written atomically; returns the paths.
    """
    plt = _pyplot()
    r = result
    outdir = Path(outdir)
    kind = r.kind
    color = "C0" if kind == "amplitude" else "purple"
    hours = r.span_days < 1
    scale = 24.0 if hours else 1.0
    x = r.days * scale
    ylab = "$y(1) = A_{corr}$" if kind == "amplitude" else "$\\phi(1)$ [rad]"
    paths = []
    with staged_outputs() as stage:
        fig, ax = plt.subplots(figsize=(5.2, 3.6), constrained_layout=True)
        ax.axhspan(r.mean - r.std, r.mean + r.std, color=color, alpha=0.18,
                   label=f"$\\pm1\\sigma$ ({r.std:.4g})")
        ax.axhline(r.mean, color=color, ls="--", lw=1.2, label=f"mean ({r.mean:.4f})")
        ax.errorbar(x, r.values, yerr=r.stderrs, fmt="o", color="k", ms=3.5, lw=1,
                    label=f"runs (n = {r.n_runs})")
        d = r.drift
        if np.isfinite(d.get("trend_per_day", np.nan)):
            tt = np.linspace(0, r.span_days, 50)
            ax.plot(tt * scale, d["intercept"] + d["trend_per_day"] * tt, color="C3", lw=1,
                    label=f"trend {d['trend_per_day'] * (1 / scale):+.2e}/"
                          f"{'h' if hours else 'day'} (p = {d['trend_p_value']:.2g})")
        ax.set_xlabel("time since first run [" + ("h" if hours else "days") + "]")
        ax.set_ylabel(ylab)
        ax.set_title(f"Fig. S2: {kind} calibration stability", fontsize=10)
        ax.legend(fontsize=7)
        path = outdir / f"figS2_stability_{kind}.png"
        fig.savefig(stage(path), dpi=130, format="png")
        plt.close(fig)
        paths.append(str(path))

        fig, ax = plt.subplots(figsize=(5.2, 3.6), constrained_layout=True)
        for c in r.curves:
            ax.plot(r.grid, c, color="0.6", lw=0.5, alpha=0.6)
        ax.fill_between(r.grid, r.mean_curve - r.std_curve, r.mean_curve + r.std_curve,
                        color=color, alpha=0.3, label="$\\pm1\\sigma$")
        ax.plot(r.grid, r.mean_curve, color=color, lw=1.6, label=f"mean of {r.n_runs} runs")
        ax.set_xlabel("RF amplitude $A$")
        ax.set_ylabel("$y(A)$" if kind == "amplitude" else "$\\phi(A)$ [rad]")
        ax.set_title(f"Fig. S3: {kind} response envelope", fontsize=10)
        ax.legend(fontsize=7)
        path = outdir / f"figS3_envelope_{kind}.png"
        fig.savefig(stage(path), dpi=130, format="png")
        plt.close(fig)
        paths.append(str(path))
    return paths
