"""Figures of the measured gate side: main-text Figs. 3, 4 and Supplement Figs. S6, S7.

:func:`fidelity_vs_rate_figure` (Fig. 3) and :func:`fidelity_vs_efficiency_figure`
(Fig. 4) draw the gate fidelities with the aligned photodiode curves,
:func:`parity_fringes_figure` every parity fringe (S7),
:func:`time_scans_figure` the population time scans (S6); each returns a
Figure and :func:`gate_figures` draws the set ``dpdfit analyze`` writes.
:func:`merged_parity_figure` draws Fig. S7 from merged parity counts alone
(``dpdfit fidelity --plot``).
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.sweep import eta_corr
from dpdfit.core.defaults import NBAR
from dpdfit.fits.alignment import K_DB
from dpdfit.models.fidelity import cardioid_populations
from dpdfit.report.figure_io import panel_grid, single_axes

__all__ = ["fidelity_vs_rate_figure", "fidelity_vs_efficiency_figure", "parity_fringes_figure",
           "time_scans_figure", "gate_figures", "merged_parity_figure"]

#: marker style per DPD flag
_STYLE = {1: dict(color="C0", marker="s", label="DPD"), 0: dict(color="C3", marker="o",
                                                             label="no DPD")}
_PARITY_COLUMNS = 4


def _setting(gate, A, dpd):
    """Rows of the gate table at one setting (A, dpd)."""
    return gate[(np.isclose(gate["A"], A)) & (gate["dpd"] == dpd)]


def _parity_points(ax, ph, k, n, color, marker):
    """Measured parity 2 k/n - 1 with its binomial error bars."""
    ax.errorbar(ph, 2 * k / n - 1, yerr=2 * np.sqrt(np.clip(k / n * (1 - k / n), 1e-12, None) / n),
                fmt=marker, mfc="none", color=color, ms=4)


def _fringe(ax, gate, parity, key, title=None):
    """One setting's parity fringe with its fitted contrast and phase."""
    ph, k, n = parity[key]
    row = _setting(gate, *key).iloc[0]
    st = _STYLE[key[1]]
    _parity_points(ax, ph, k, n, st["color"], st["marker"])
    x = np.linspace(0, 2 * np.pi, 300)
    ax.plot(x, row["contrast"] * np.cos(2 * x + row["phi0"]), color=st["color"],
            label=f"A={key[0]:g} {st['label']}: C={row['contrast']:.3f}")
    ax.set(xlabel="analysis phase $\\varphi$ (rad)", ylabel="parity $\\Pi$",
           ylim=(-1.1, 1.1), title=title)
    ax.legend(fontsize=7, loc="lower left")


def _rate_panel(ax, gate, mean, fit, highlight):
    """Fig. 3: fidelity versus gate rate, with the aligned photodiode curves and their band."""
    for d in (1, 0):
        g = gate[gate["dpd"] == d]
        # without stated gate-rate errors (xi0_err_khz is optional): no horizontal bars
        ax.errorbar(g["xi0_khz"], g["F"], xerr=g.get("xi0_err_khz"), yerr=g["F_err"],
                    fmt=_STYLE[d]["marker"], color=_STYLE[d]["color"],
                    label=f"gate, {_STYLE[d]['label']}")
        if fit is not None:
            c = mean[mean["dpd"] == d].sort_values("A")
            xi = fit.alpha_khz * c["r_rel"].to_numpy()
            F = c["F_est"].to_numpy() + fit.delta
            band = xi * K_DB * fit.sigma_db
            ax.plot(xi, F, color=_STYLE[d]["color"], label=f"photodiode, {_STYLE[d]['label']}")
            ax.fill_betweenx(F, xi - band, xi + band, color=_STYLE[d]["color"], alpha=0.15)
    if highlight:
        for key in highlight:
            row = _setting(gate, *key)
            if len(row):
                ax.plot(row["xi0_khz"], row["F"], "o", mfc="none", mec="k", ms=12, mew=2)
    lo = np.nanmin(gate["F"]) - 0.03
    ax.set(xlabel="gate rate $\\xi_0$ (kHz)", ylabel="Bell-state fidelity",
           xlim=(0.9 * gate["xi0_khz"].min(), 1.1 * gate["xi0_khz"].max()),
           ylim=(lo, 1.0), title="fidelity vs gate rate (Fig. 3)")
    ax.legend(fontsize=7)


def _mean(sweep):
    return sweep[sweep["sideband"] == "mean"]


def fidelity_vs_rate_figure(gate, sweep, fit=None, parity=None, highlight=None, *, fig=None):
    """Fig. 3: fidelity versus gate rate, with the aligned photodiode curves and their band.

    With ``highlight`` (a pair of settings ``(A, dpd)``) and ``parity`` the
    pair's parity fringes go into a second panel beside it.  Arguments as
    :func:`gate_figures`; drawn into ``fig`` (an empty Figure or SubFigure)
    when given; returns the Figure.
    """
    ncols = 2 if (highlight and parity) else 1
    fig, axes = panel_grid(fig, 1, ncols, (5.2 * ncols, 4))
    _rate_panel(axes[0, 0], gate, _mean(sweep), fit, highlight)
    if ncols == 2:
        for key in highlight:
            if key in parity:
                _fringe(axes[0, 1], gate, parity, key, "highlighted pair: parity fringes")
    return fig


def fidelity_vs_efficiency_figure(gate, sweep, fit=None, *, ax=None):
    """Fig. 4: fidelity versus the time-averaged efficiency eta_bar.

    Arguments as :func:`gate_figures`; drawn into ``ax`` when given; returns the Figure.
    """
    fig, ax = single_axes(ax, (5.2, 4))
    ec = eta_corr(sweep)
    mean = _mean(sweep)
    for d in (1, 0):
        c = mean[mean["dpd"] == d].sort_values("A")
        shift = fit.delta if fit is not None else 0.0
        ax.plot(c["eta_bar"], c["F_est"] + shift, color=_STYLE[d]["color"],
                label=f"photodiode{' + delta' if fit is not None else ''}, {_STYLE[d]['label']}")
        if fit is not None:
            p = fit.points[fit.points["dpd"] == d]
            ax.errorbar(p["eta_bar"], p["F"], yerr=p["F_err"], fmt=_STYLE[d]["marker"],
                        color=_STYLE[d]["color"], label=f"gate, {_STYLE[d]['label']}")
        key = "dpd" if d == 1 else "no_dpd"
        if ec.get(key):
            ax.axvline(ec[key], color=_STYLE[d]["color"], ls="--", lw=1)
    ax.set(xlabel="time-averaged diffraction efficiency $\\bar\\eta$",
           ylabel="Bell-state fidelity", ylim=(np.nanmin(gate["F"]) - 0.03, 1.0),
           title="fidelity vs efficiency (Fig. 4)")
    ax.legend(fontsize=7)
    return fig


def _grid_axes(fig, n_panels, min_rows=0):
    """``(figure, axes)``: a grid of 4 columns for ``n_panels`` panels (axes beyond them off)."""
    nr = max(min_rows, -(-n_panels // _PARITY_COLUMNS))
    fig, axes = panel_grid(fig, nr, _PARITY_COLUMNS, (3.2 * _PARITY_COLUMNS, 2.6 * nr))
    for ax in list(axes.flat)[n_panels:]:
        ax.axis("off")
    return fig, axes


def parity_fringes_figure(gate, parity, *, fig=None):
    """Fig. S7: every setting's parity fringe with its fitted contrast and phase.

    ``parity``: ``{(A, dpd): (phases, n_even, shots)}``; the fits are drawn from
    ``gate``'s ``contrast`` and ``phi0``.  Drawn into ``fig`` (an empty Figure
    or SubFigure) when given; returns the Figure.
    """
    keys = sorted(parity)
    fig, axes = _grid_axes(fig, len(keys))
    for ax, key in zip(axes.flat, keys):
        _fringe(ax, gate, parity, key)
    return fig


def _time_scan_panel(ax, gate, ts, d, nbar):
    """One flag's population time scan with the ideal Cardioid model at its gate rate."""
    A = float(ts["A"].iloc[0])
    row = _setting(gate, A, d)
    N = ts["shots"].to_numpy()
    for col, lab, c, m in (("n00", "$P_{00}$", "C0", "o"),
                           ("n01_10", "$P_{01}+P_{10}$", "C1", "s"),
                           ("n11", "$P_{11}$", "C2", "^")):
        p = ts[col].to_numpy() / N
        ax.errorbar(ts["t_us"], p, yerr=np.sqrt(p * (1 - p) / N), fmt=m, mfc="none",
                    color=c, ms=4, label=lab)
    if len(row):
        xi0 = float(row["xi0_khz"].iloc[0]) * 1e3
        t = np.linspace(0, ts["t_us"].max() * 1e-6, 400)
        P = cardioid_populations(t, xi0, nbar)
        for j, c in enumerate(("C0", "C1", "C2")):
            ax.plot(t * 1e6, P[:, j], color=c)
        ax.axvline(1e6 / xi0, color="k", ls="--", lw=1)
    ax.set(xlabel="time ($\\mu$s)", ylabel="population", ylim=(-0.02, 1.02),
           title=f"A = {A:g}, {_STYLE[d]['label']}")
    ax.legend(fontsize=7)


def time_scans_figure(gate, time_scans, nbar: float = NBAR, *, fig=None):
    """Fig. S6: the population time scans, one panel per DPD flag, with the ideal Cardioid
    model at the setting's gate rate.

    ``time_scans``: ``A, dpd, t_us, n00, n01_10, n11, shots``.  Drawn into
    ``fig`` (an empty Figure or SubFigure) when given; returns the Figure.
    """
    flags = sorted(time_scans["dpd"].unique(), reverse=True)
    fig, axes = panel_grid(fig, 1, len(flags), (5 * len(flags), 3.8))
    for ax, d in zip(axes.flat, flags):
        ts = time_scans[time_scans["dpd"] == d].sort_values("t_us")
        _time_scan_panel(ax, gate, ts, d, nbar)
    return fig


def gate_figures(gate, sweep, fit, parity=None, time_scans=None, highlight=None,
                 nbar: float = NBAR) -> dict:
    """Figures of the measured side as ``dpdfit analyze`` writes them: ``{file stem: Figure}``.

    ``fig3_fidelity_vs_rate``, ``fig4_fidelity_vs_eta``, ``figS7_parity_fringes``
    (with ``parity``) and ``figS6_time_scans`` (with ``time_scans``).

    Parameters
    ----------
    gate : DataFrame
        ``A, dpd, xi0_khz, F, F_err`` (+ ``xi0_err_khz``, ``contrast``, ``phi0``).
    sweep : DataFrame
        The simulated sweep (for the photodiode curves).
    fit : AlignmentFit or None
        Alignment result (curves are drawn shifted by ``delta`` on the
        ``alpha r_rel`` axis, with the power-fluctuation band).
    parity : dict, optional
        ``{(A, dpd): (phases, n_even, shots)}`` merged parity data (fits are
        drawn from ``gate``'s ``contrast`` and ``phi0``).
    time_scans : DataFrame, optional
        ``A, dpd, t_us, n00, n01_10, n11, shots``.
    highlight : ((A, dpd), (A, dpd)), optional
        The pair whose parity fringes go into Fig. 3's side panel.
    """
    figs = {"fig3_fidelity_vs_rate": fidelity_vs_rate_figure(gate, sweep, fit, parity, highlight),
            "fig4_fidelity_vs_eta": fidelity_vs_efficiency_figure(gate, sweep, fit)}
    if parity:
        figs["figS7_parity_fringes"] = parity_fringes_figure(gate, parity)
    if time_scans is not None and len(time_scans):
        figs["figS6_time_scans"] = time_scans_figure(gate, time_scans, nbar)
    return figs


def merged_parity_figure(gate, merged_parity, *, fig=None):
    """Fig. S7 alone (``dpdfit fidelity --plot``): merged parity fringes of every setting
    with their fits.

    ``merged_parity`` is the DataFrame of :func:`dpdfit.fits.counts.merge_parity`
    (``A, dpd, phase_rad, n_even, shots``); the fits come from ``gate``'s
    ``contrast`` and ``phi0``.  Drawn into ``fig`` (an empty Figure or
    SubFigure) when given; returns the Figure.
    """
    parity = {}
    for (A, d), g in merged_parity.groupby(["A", "dpd"]):
        parity[(float(A), int(d))] = (g["phase_rad"].to_numpy(), g["n_even"].to_numpy(),
                                      g["shots"].to_numpy())
    keys = sorted(parity)
    fig, axes = _grid_axes(fig, len(keys), min_rows=1)
    for ax, key in zip(axes.flat, keys):
        ph, k, n = parity[key]
        row = _setting(gate, *key).iloc[0]
        c = "C0" if key[1] else "C3"
        _parity_points(ax, ph, k, n, c, "s" if key[1] else "o")
        x = np.linspace(0, 2 * np.pi, 300)
        ax.plot(x, row["contrast"] * np.cos(2 * x + row["phi0"]), color=c)
        ax.set(title=f"A={key[0]:g} {'DPD' if key[1] else 'no DPD'}: C={row['contrast']:.3f}",
               ylim=(-1.1, 1.1), xlabel="$\\varphi$ (rad)", ylabel="$\\Pi$")
    return fig
