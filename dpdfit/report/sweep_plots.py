"""Figures of the amplitude sweep: Figs. 2, 5 and Supplement Figs. S3, S5.

Simulated curves are dashed, as in the paper; curves measured from the
recorded spectra (the table of
:func:`dpdfit.analyses.measured_spectra.measured_spectra`) are solid.

:func:`spectral_figure` (Fig. 2), :func:`spectral_supplement_figure` (S6),
:func:`infidelity_vs_efficiency_figure` (Fig. 5), :func:`phase_space_figure`
(S4) each return a Figure; :func:`sweep_figures` draws the set ``dpdfit
analyze`` writes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from dpdfit.analyses.sweep import thresholds
from dpdfit.models.fidelity import calibrate_g, phase_space
from dpdfit.report.figure_io import panel_grid, single_axes

__all__ = ["spectral_figure", "spectral_supplement_figure", "infidelity_vs_efficiency_figure",
           "phase_space_figure", "sweep_figures"]

#: simulated curve style per DPD flag
_STYLE = {1: dict(color="C0", ls="--", label="DPD (sim.)"),
          0: dict(color="C3", ls="--", label="no DPD (sim.)")}
_LEVELS = {"1e-2": 1e-2, "1e-3": 1e-3, "1e-4": 1e-4}
_A_LABEL = "normalised RF amplitude $A$"


@dataclass(frozen=True)
class _Curves:
    """What the panels draw: sideband-mean rows per DPD flag, simulated and measured."""

    sim: dict                      # {1: DataFrame, 0: DataFrame} sorted by A
    meas: pd.DataFrame | None      # measured sideband-mean rows (both flags) or None
    A_corr: float | None


def _measured_line(ax, c: _Curves, d, x, y, valid_col=None):
    if c.meas is None:
        return
    sub = c.meas[c.meas["dpd"] == d].sort_values("A")
    if valid_col is not None:
        sub = sub[sub[valid_col] == 1]
    ax.plot(sub[x], sub[y], color=_STYLE[d]["color"], ls="-", marker=".", ms=3,
            label=_STYLE[d]["label"].replace("sim.", "measured"))


def _ratio_panel(ax, c: _Curves, col, title):
    """R10 or R23 versus A (measured only where the IM tone was above the noise floor)."""
    for d in (1, 0):
        ax.plot(c.sim[d]["A"], c.sim[d][col], **_STYLE[d])
        _measured_line(ax, c, d, "A", col, "P0_valid" if col == "R10_dB" else "P3_valid")
    if c.A_corr:
        ax.axvline(c.A_corr, color="0.5", ls="--", lw=1)
    ax.set(xlabel=_A_LABEL, ylabel=col.replace("_dB", " (dB)"), title=title)
    ax.legend(fontsize=7)


def _dp_panel(ax, c: _Curves, title):
    """Change of the gate-tone powers with DPD, dP_1 and dP_2, versus A."""
    d1 = c.sim[1]
    ax.plot(d1["A"], d1["dP1_dB"], color="green", ls="--", label="$\\Delta P_1$")
    ax.plot(d1["A"], d1["dP2_dB"], color="purple", ls=":", label="$\\Delta P_2$")
    if c.meas is not None:
        sub = c.meas[c.meas["dpd"] == 1].sort_values("A")
        ax.plot(sub["A"], sub["dP1_dB"], color="green", marker=".", ms=3, ls="-",
                label="$\\Delta P_1$ measured")
        ax.plot(sub["A"], sub["dP2_dB"], color="purple", marker=".", ms=3, ls="-",
                label="$\\Delta P_2$ measured")
    ax.axhline(0, color="0.7", lw=0.8)
    if c.A_corr:
        ax.axvline(c.A_corr, color="0.5", ls="--", lw=1)
    ax.set(xlabel=_A_LABEL, ylabel="$\\Delta P_n$ (dB)", title=title)
    ax.legend(fontsize=7)


def _threshold_marks(ax, th: dict):
    """Infidelity levels with the simulated eta_th marked, and the eta_bar_corr lines."""
    for (lev, val), col in zip(_LEVELS.items(), ("green", "purple", "goldenrod")):
        ax.axhline(val, color=col, ls="--", lw=0.8)
        for key in ("dpd", "no_dpd"):
            x = th["eta_th"][key][lev]
            if x:
                ax.plot([x], [val], "ko", ms=3)
                ax.annotate(f"{x:.3f}", (x, val), fontsize=6, xytext=(2, 3),
                            textcoords="offset points")
    for key, col in (("dpd", "C0"), ("no_dpd", "C3")):
        x = th["eta_corr"].get(key)
        if x:
            ax.axvline(x, color=col, ls="-.", lw=1)


def _eps_panel(ax, c: _Curves, th: dict):
    """eps_est versus eta_bar, log-log (Fig. 5)."""
    has_meas = c.meas is not None
    for d in (1, 0):
        sub = c.sim[d]
        ok = (sub["eps_est"] > 0) & (sub["eta_bar"] > 0)
        ax.loglog(sub["eta_bar"][ok], sub["eps_est"][ok], color=_STYLE[d]["color"],
                  ls="--" if has_meas else "-",
                  label=_STYLE[d]["label"].replace(" (sim.)", "") + (" (sim.)" if has_meas else ""))
        if has_meas:
            ms = c.meas[(c.meas["dpd"] == d) & (c.meas["eps_est"] > 0)].sort_values("eta_bar")
            ax.loglog(ms["eta_bar"], ms["eps_est"], color=_STYLE[d]["color"], ls="-",
                      marker=".", ms=3, label=_STYLE[d]["label"].replace("sim.", "measured"))
    _threshold_marks(ax, th)
    ax.set(xlabel="time-averaged diffraction efficiency $\\bar\\eta$",
           ylabel="$\\epsilon_{est} = 1 - F_{est}$", title="estimated infidelity")
    ax.legend(fontsize=7)


def _phase_space_panel(ax):
    """Trajectory of Cardioid(1,2), ideal and with a 10 % n = 0 or n = 3 tone (Fig. S3)."""
    x = np.linspace(0, 2 * np.pi, 800)
    s = 1 / np.sqrt(1.5)
    for n_im, col, lab in ((None, "0.5", "ideal"), (0, "m", "n = 0 tone (10 %)"),
                           (3, "C0", "n = 3 tone (10 %)")):
        n = np.array([1, 2] + ([] if n_im is None else [n_im]))
        r = np.array([s, -s] + ([] if n_im is None else [0.1]))
        g = calibrate_g(n, r, (1, 2))
        F, G, _ = phase_space(n, r, 0.0, g, x)
        ax.plot(F, G, color=col, ls="--" if n_im is None else "-", label=lab)
        ax.plot(F[-1], G[-1], "s", color=col, ms=4)
    ax.plot(0, 0, "ko", ms=3)
    ax.set(xlabel="$F$", ylabel="$G$", title="phase space (Fig. S3)", aspect="equal")
    ax.legend(fontsize=7)


def _curves(df, measured) -> _Curves:
    """The sideband-mean curves of the simulated sweep ``df`` and of ``measured`` (or None)."""
    mean = df[df["sideband"] == "mean"]
    return _Curves(sim={d: mean[mean["dpd"] == d].sort_values("A") for d in (1, 0)},
                   meas=None if measured is None else measured[measured["sideband"] == "mean"],
                   A_corr=df.attrs.get("A_corr"))


def _row(fig, panels):
    """The panels side by side in ``fig`` (or a new figure); returns the Figure."""
    fig, axes = panel_grid(fig, 1, len(panels), (4.4 * len(panels), 3.6))
    for ax, draw in zip(axes.flat, panels):
        draw(ax)
    return fig


def spectral_figure(df, measured=None, *, fig=None):
    """Fig. 2: (a) R10 versus A, (b) the gate-tone power changes dP_n versus A.

    ``df``: the simulated sweep (:func:`dpdfit.analyses.sweep.run_sweep`);
    ``measured``: the table of
    :func:`dpdfit.analyses.measured_spectra.measured_spectra` (solid lines; the
    ratios only where the IM tone was above the noise floor), or None.  Drawn
    into ``fig`` (an empty Figure or SubFigure) when given; returns the Figure.
    """
    c = _curves(df, measured)
    return _row(fig, [lambda ax: _ratio_panel(ax, c, "R10_dB", "(a) $R_{10}$"),
                      lambda ax: _dp_panel(ax, c, "(b) gate-tone power change")])


def spectral_supplement_figure(df, measured=None, *, fig=None):
    """Fig. S5: (a) R10, (b) R23, (c) dP_n versus A (arguments as :func:`spectral_figure`)."""
    c = _curves(df, measured)
    return _row(fig, [lambda ax: _ratio_panel(ax, c, "R10_dB", "(a) $R_{10}$"),
                      lambda ax: _ratio_panel(ax, c, "R23_dB", "(b) $R_{23}$"),
                      lambda ax: _dp_panel(ax, c, "(c) $\\Delta P_n$")])


def infidelity_vs_efficiency_figure(df, measured=None, *, ax=None):
    """Fig. 5: eps_est versus eta_bar, log-log, with the infidelity thresholds and eta_bar_corr.

    Arguments as :func:`spectral_figure`; drawn into ``ax`` when given; returns the Figure.
    """
    fig, ax = single_axes(ax, (4.4, 3.6))
    _eps_panel(ax, _curves(df, measured), thresholds(df))
    return fig


def phase_space_figure(*, ax=None):
    """Fig. S3: trajectory of Cardioid(1,2), ideal and with a 10 % n = 0 or n = 3 tone.

    Drawn into ``ax`` when given; returns the Figure.
    """
    fig, ax = single_axes(ax, (4.4, 3.6))
    _phase_space_panel(ax)
    return fig


def sweep_figures(df, measured=None) -> dict:
    """The figures of the amplitude sweep as ``dpdfit analyze`` writes them: ``{file stem: Figure}``.

    ``fig2_spectral`` (:func:`spectral_figure`), ``figS5_spectral``
    (:func:`spectral_supplement_figure`), ``fig5_eps_vs_eta``
    (:func:`infidelity_vs_efficiency_figure`) and ``figS3_phase_space``
    (:func:`phase_space_figure`).  ``df`` is the simulated sweep; ``measured``
    (the table of :func:`dpdfit.analyses.measured_spectra.measured_spectra` with
    columns ``A, dpd, sideband, R10_dB, R23_dB, dP1_dB, dP2_dB, eta_bar,
    eps_est, P0_valid, P3_valid``) adds the recorded curves as solid lines.
    """
    return {"fig2_spectral": spectral_figure(df, measured),
            "figS5_spectral": spectral_supplement_figure(df, measured),
            "fig5_eps_vs_eta": infidelity_vs_efficiency_figure(df, measured),
            "figS3_phase_space": phase_space_figure()}
