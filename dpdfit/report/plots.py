"""Figures (matplotlib, Agg backend).  Plotting stays at the edge of the package.

:func:`plot_calibration` draws the paper's Fig. 1: (a) amplitude data, fit,
confidence band and the linearised response under DPD; (b) phase data, fit
and band; (c) the predistortion function.
"""

from __future__ import annotations

import os

import numpy as np

from dpdfit.recordings.outputs import staged_outputs
from dpdfit.fits.calibration import Calibration
from dpdfit.recordings.tables import CalibrationData
from dpdfit.models.transfer import TransferFunction

__all__ = ["plot_calibration"]


def _pyplot():
    import matplotlib
    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt
    return plt


def plot_calibration(cal: Calibration, outdir: str | os.PathLike,
                     amp_data: CalibrationData | None = None,
                     phase_data: CalibrationData | None = None) -> list[str]:
    """Write Fig. 1 (a), (b), (c) as PNG files into ``outdir``.

    Returns the list of written paths: ``fig1a_amplitude.png``,
    ``fig1b_phase.png`` (if a phase calibration is present),
    ``fig1c_predistortion.png`` and ``fig1_calibration.png`` (all panels).
    Panel (c) is left out when the fit is not invertible (the reason is
    written in its place).
    """
    plt = _pyplot()
    amp = cal.amplitude
    tf = TransferFunction.from_calibration(cal)
    Ac = amp.A_corr
    A = np.linspace(0, 1, 501)
    try:
        tf.invertibility()
        inv_err = None
    except Exception as exc:  # NotInvertibleError: show it, do not fail the plot
        inv_err = str(exc)

    def panel_a(ax):
        if amp_data is not None:
            p = amp_data.value
            ydat = np.sign(p) * np.sqrt(np.abs(p)) / amp.raw_coefficients[0]
            ax.plot(amp_data.A, ydat, "kx", ms=4, label="data (signed $\\sqrt{P}$, normalised)")
        yfit, band = amp.y(A), amp.y_stderr(A)
        ax.plot(A, yfit, "C0-", label=f"K={amp.order} fit")
        ax.fill_between(A, yfit - 2 * band, yfit + 2 * band, color="C0", alpha=0.25,
                        label="fit $\\pm2\\sigma$")
        if inv_err is None:
            lin = tf.f_am(tf.inverse_am(A))
            ax.plot(A, lin, "m-", lw=1.5, label="with DPD")
        ax.plot(A, A, color="0.6", ls=":", lw=1)
        ax.axvline(Ac, color="k", ls="--", lw=1)
        ax.text(Ac, 0.02, f" $A_{{corr}}$={Ac:.4f}", fontsize=8)
        ax.set(xlabel="normalised RF amplitude $A$", ylabel="optical amplitude $y$",
               xlim=(0, 1), ylim=(0, max(0.7, float(yfit.max()) * 1.1)), title="(a) amplitude")
        if not amp.monotone:
            for a, b in amp.nonmonotone_intervals:
                ax.axvspan(a, b, color="r", alpha=0.15)
        ax.legend(fontsize=7, loc="upper left")

    def panel_b(ax):
        ph = cal.phase
        if phase_data is not None:
            inside = (phase_data.A >= ph.A_min) & (phase_data.A <= ph.A_max)
            ax.plot(phase_data.A[inside], phase_data.value[inside], "kx", ms=4, label="data (fitted)")
            ax.plot(phase_data.A[~inside], phase_data.value[~inside], "x", color="0.6", ms=4,
                    label="data (excluded)")
        f, band = ph.phi(A), ph.phi_stderr(A)
        ax.plot(A, f, color="purple", label=f"K={ph.order} fit, {ph.A_min:g}$\\leq A\\leq${ph.A_max:g}")
        ax.fill_between(A, f - 2 * band, f + 2 * band, color="purple", alpha=0.25,
                        label="fit $\\pm2\\sigma$")
        lo = min(0.0, float(np.min(f))) - 0.02
        hi = float(np.max(f)) * 1.15 + 0.02
        ax.set(xlabel="normalised RF amplitude $A$", ylabel="phase $\\phi$ (rad)", xlim=(0, 1),
               ylim=(lo, hi), title="(b) phase")
        ax.legend(fontsize=7, loc="upper left")

    def panel_c(ax):
        if inv_err is not None:
            ax.text(0.5, 0.5, "not invertible:\n" + inv_err[:120], ha="center", va="center",
                    fontsize=7, wrap=True, transform=ax.transAxes)
            ax.set_title("(c) predistortion")
            return
        ax.plot(A, tf.inverse_am(A), color="orange", label="$f_{AM}^{-1}$ (clamped beyond $A_{corr}$)")
        ax.plot(A, A, color="0.6", ls=":", lw=1, label="$y=A$")
        ax.axvline(Ac, color="k", ls="--", lw=1)
        ax.set(xlabel="target optical amplitude", ylabel="RF amplitude $A$", xlim=(0, 1),
               ylim=(0, 1.05), title="(c) predistortion")
        ax.legend(fontsize=7, loc="lower right")

    panels = [("fig1a_amplitude.png", panel_a)]
    if cal.phase is not None:
        panels.append(("fig1b_phase.png", panel_b))
    panels.append(("fig1c_predistortion.png", panel_c))
    written = []
    with staged_outputs() as stage:
        for name, draw in panels:
            fig, ax = plt.subplots(figsize=(4.2, 3.4), constrained_layout=True)
            draw(ax)
            path = os.path.join(outdir, name)
            fig.savefig(stage(path), dpi=130, format="png")
            plt.close(fig)
            written.append(path)
        fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.6),
                                 constrained_layout=True)
        for ax, (_, draw) in zip(np.atleast_1d(axes), panels):
            draw(ax)
        path = os.path.join(outdir, "fig1_calibration.png")
        fig.savefig(stage(path), dpi=130, format="png")
        plt.close(fig)
        written.append(path)
    return written


def plot_sweep(df, outdir: str | os.PathLike, measured=None) -> list[str]:
    """Figures of the amplitude sweep, as PNG files in ``outdir``.

    ``fig2_spectral.png`` (a: R10 vs A, b: dP_n vs A), ``figS6_spectral.png``
    (a: R10, b: R23, c: dP_n), ``fig5_eps_vs_eta.png`` (eps_est vs eta_bar,
    log-log, thresholds and eta_bar_corr) and ``figS4_phase_space.png``
    (trajectory of Cardioid(1,2) with a 10 % n = 0 or n = 3 tone).
    Simulations are dashed, as in the paper; ``measured`` (the table of
    :func:`dpdfit.pipeline.analyze` with columns ``A, dpd, sideband, R10_dB, R23_dB,
    dP1_dB, dP2_dB, eta_bar, eps_est, P0_valid, P3_valid``) adds the
    recorded curves as solid lines (ratios only where the IM tone was above
    the noise floor).
    """
    from dpdfit.models.fidelity import calibrate_g, phase_space
    from dpdfit.analyses.sweep import thresholds

    plt = _pyplot()
    Ac = df.attrs.get("A_corr")
    mean = df[df["sideband"] == "mean"]
    d1 = mean[mean["dpd"] == 1].sort_values("A")
    d0 = mean[mean["dpd"] == 0].sort_values("A")
    style = {1: dict(color="C0", ls="--", label="DPD (sim.)"),
             0: dict(color="C3", ls="--", label="no DPD (sim.)")}

    meas = None if measured is None else measured[measured["sideband"] == "mean"]

    def measured_line(ax, d, x, y, valid_col=None):
        if meas is None:
            return
        sub = meas[meas["dpd"] == d].sort_values("A")
        if valid_col is not None:
            sub = sub[sub[valid_col] == 1]
        ax.plot(sub[x], sub[y], color=style[d]["color"], ls="-", marker=".", ms=3,
                label=style[d]["label"].replace("sim.", "measured"))

    def ratio_panel(ax, col, title):
        for d, sub in ((1, d1), (0, d0)):
            ax.plot(sub["A"], sub[col], **style[d])
            measured_line(ax, d, "A", col, "P0_valid" if col == "R10_dB" else "P3_valid")
        if Ac:
            ax.axvline(Ac, color="0.5", ls="--", lw=1)
        ax.set(xlabel="normalised RF amplitude $A$", ylabel=col.replace("_dB", " (dB)"),
               title=title)
        ax.legend(fontsize=7)

    def dp_panel(ax, title):
        ax.plot(d1["A"], d1["dP1_dB"], color="green", ls="--", label="$\\Delta P_1$")
        ax.plot(d1["A"], d1["dP2_dB"], color="purple", ls=":", label="$\\Delta P_2$")
        if meas is not None:
            sub = meas[meas["dpd"] == 1].sort_values("A")
            ax.plot(sub["A"], sub["dP1_dB"], color="green", marker=".", ms=3, ls="-",
                    label="$\\Delta P_1$ measured")
            ax.plot(sub["A"], sub["dP2_dB"], color="purple", marker=".", ms=3, ls="-",
                    label="$\\Delta P_2$ measured")
        ax.axhline(0, color="0.7", lw=0.8)
        if Ac:
            ax.axvline(Ac, color="0.5", ls="--", lw=1)
        ax.set(xlabel="normalised RF amplitude $A$", ylabel="$\\Delta P_n$ (dB)", title=title)
        ax.legend(fontsize=7)

    th = thresholds(df)

    def eps_panel(ax):
        for d, sub in ((1, d1), (0, d0)):
            ok = (sub["eps_est"] > 0) & (sub["eta_bar"] > 0)
            ax.loglog(sub["eta_bar"][ok], sub["eps_est"][ok], color=style[d]["color"],
                      ls="--" if meas is not None else "-",
                      label=style[d]["label"].replace(" (sim.)", "") + (" (sim.)" if meas is not None else ""))
            if meas is not None:
                ms = meas[(meas["dpd"] == d) & (meas["eps_est"] > 0)].sort_values("eta_bar")
                ax.loglog(ms["eta_bar"], ms["eps_est"], color=style[d]["color"], ls="-",
                          marker=".", ms=3, label=style[d]["label"].replace("sim.", "measured"))
        for (lev, val), c in zip({"1e-2": 1e-2, "1e-3": 1e-3, "1e-4": 1e-4}.items(),
                                 ("green", "purple", "goldenrod")):
            ax.axhline(val, color=c, ls="--", lw=0.8)
            for key in ("dpd", "no_dpd"):
                x = th["eta_th"][key][lev]
                if x:
                    ax.plot([x], [val], "ko", ms=3)
                    ax.annotate(f"{x:.3f}", (x, val), fontsize=6, xytext=(2, 3),
                                textcoords="offset points")
        for key, c in (("dpd", "C0"), ("no_dpd", "C3")):
            x = th["eta_corr"].get(key)
            if x:
                ax.axvline(x, color=c, ls="-.", lw=1)
        ax.set(xlabel="time-averaged diffraction efficiency $\\bar\\eta$",
               ylabel="$\\epsilon_{est} = 1 - F_{est}$", title="estimated infidelity")
        ax.legend(fontsize=7)

    def phase_space_panel(ax):
        x = np.linspace(0, 2 * np.pi, 800)
        s = 1 / np.sqrt(1.5)
        for n_im, c, lab in ((None, "0.5", "ideal"), (0, "m", "n = 0 tone (10 %)"),
                             (3, "C0", "n = 3 tone (10 %)")):
            n = np.array([1, 2] + ([] if n_im is None else [n_im]))
            r = np.array([s, -s] + ([] if n_im is None else [0.1]))
            g = calibrate_g(n, r, (1, 2))
            F, G, _ = phase_space(n, r, 0.0, g, x)
            ax.plot(F, G, color=c, ls="--" if n_im is None else "-", label=lab)
            ax.plot(F[-1], G[-1], "s", color=c, ms=4)
        ax.plot(0, 0, "ko", ms=3)
        ax.set(xlabel="$F$", ylabel="$G$", title="phase space (Fig. S4)", aspect="equal")
        ax.legend(fontsize=7)

    figures = {
        "fig2_spectral.png": [lambda ax: ratio_panel(ax, "R10_dB", "(a) $R_{10}$"),
                              lambda ax: dp_panel(ax, "(b) gate-tone power change")],
        "figS6_spectral.png": [lambda ax: ratio_panel(ax, "R10_dB", "(a) $R_{10}$"),
                               lambda ax: ratio_panel(ax, "R23_dB", "(b) $R_{23}$"),
                               lambda ax: dp_panel(ax, "(c) $\\Delta P_n$")],
        "fig5_eps_vs_eta.png": [eps_panel],
        "figS4_phase_space.png": [phase_space_panel],
    }
    written = []
    with staged_outputs() as stage:
        for name, panels in figures.items():
            fig, axes = plt.subplots(1, len(panels), figsize=(4.4 * len(panels), 3.6),
                                     constrained_layout=True)
            for ax, draw in zip(np.atleast_1d(axes), panels):
                draw(ax)
            path = os.path.join(outdir, name)
            fig.savefig(stage(path), dpi=130, format="png")
            plt.close(fig)
            written.append(path)
    return written


def _save(plt, fig, stage, outdir, name, written):
    path = os.path.join(outdir, name)
    fig.savefig(stage(path), dpi=130, format="png")
    plt.close(fig)
    written.append(path)


def plot_gate_figures(gate, sweep, fit, outdir, parity=None, time_scans=None,
                      highlight=None, nbar: float = 0.1) -> list[str]:
    """Figures of the measured side (main-text Figs. 3, 4; Supplement Figs. S7, S8).

    Parameters
    ----------
    gate : DataFrame
        ``A, dpd, xi0_khz, xi0_err_khz, F, F_err`` (+ ``contrast``, ``phi0``).
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
    from dpdfit.fits.alignment import K_DB
    from dpdfit.models.fidelity import cardioid_populations
    from dpdfit.analyses.sweep import eta_corr

    plt = _pyplot()
    style = {1: dict(color="C0", marker="s", label="DPD"), 0: dict(color="C3", marker="o",
                                                                  label="no DPD")}
    written: list[str] = []
    mean = sweep[sweep["sideband"] == "mean"]

    def fringe(ax, key, title=None):
        ph, k, n = parity[key]
        row = gate[(np.isclose(gate["A"], key[0])) & (gate["dpd"] == key[1])].iloc[0]
        ax.errorbar(ph, 2 * k / n - 1, yerr=2 * np.sqrt(np.clip(k / n * (1 - k / n), 1e-12, None) / n),
                    fmt=style[key[1]]["marker"], mfc="none", color=style[key[1]]["color"], ms=4)
        x = np.linspace(0, 2 * np.pi, 300)
        ax.plot(x, row["contrast"] * np.cos(2 * x + row["phi0"]), color=style[key[1]]["color"],
                label=f"A={key[0]:g} {style[key[1]]['label']}: C={row['contrast']:.3f}")
        ax.set(xlabel="analysis phase $\\varphi$ (rad)", ylabel="parity $\\Pi$",
               ylim=(-1.1, 1.1), title=title)
        ax.legend(fontsize=7, loc="lower left")

    with staged_outputs() as stage:
        # Fig. 3: fidelity vs gate rate
        ncols = 2 if (highlight and parity) else 1
        fig, axes = plt.subplots(1, ncols, figsize=(5.2 * ncols, 4), constrained_layout=True)
        ax = np.atleast_1d(axes)[0]
        for d in (1, 0):
            g = gate[gate["dpd"] == d]
            ax.errorbar(g["xi0_khz"], g["F"], xerr=g["xi0_err_khz"], yerr=g["F_err"],
                        fmt=style[d]["marker"], color=style[d]["color"], label=f"gate, {style[d]['label']}")
            if fit is not None:
                c = mean[mean["dpd"] == d].sort_values("A")
                xi = fit.alpha_khz * c["r_rel"].to_numpy()
                F = c["F_est"].to_numpy() + fit.delta
                band = xi * K_DB * fit.sigma_db
                ax.plot(xi, F, color=style[d]["color"], label=f"photodiode, {style[d]['label']}")
                ax.fill_betweenx(F, xi - band, xi + band, color=style[d]["color"], alpha=0.15)
        if highlight:
            for key in highlight:
                row = gate[(np.isclose(gate["A"], key[0])) & (gate["dpd"] == key[1])]
                if len(row):
                    ax.plot(row["xi0_khz"], row["F"], "o", mfc="none", mec="k", ms=12, mew=2)
        lo = np.nanmin(gate["F"]) - 0.03
        ax.set(xlabel="gate rate $\\xi_0$ (kHz)", ylabel="Bell-state fidelity",
               xlim=(0.9 * gate["xi0_khz"].min(), 1.1 * gate["xi0_khz"].max()),
               ylim=(lo, 1.0), title="fidelity vs gate rate (Fig. 3)")
        ax.legend(fontsize=7)
        if ncols == 2:
            ax2 = np.atleast_1d(axes)[1]
            for key in highlight:
                if key in parity:
                    fringe(ax2, key, "highlighted pair: parity fringes")
        _save(plt, fig, stage, outdir, "fig3_fidelity_vs_rate.png", written)

        # Fig. 4: fidelity vs eta_bar
        fig, ax = plt.subplots(figsize=(5.2, 4), constrained_layout=True)
        ec = eta_corr(sweep)
        for d in (1, 0):
            c = mean[mean["dpd"] == d].sort_values("A")
            shift = fit.delta if fit is not None else 0.0
            ax.plot(c["eta_bar"], c["F_est"] + shift, color=style[d]["color"],
                    label=f"photodiode{' + delta' if fit is not None else ''}, {style[d]['label']}")
            if fit is not None:
                p = fit.points[fit.points["dpd"] == d]
                ax.errorbar(p["eta_bar"], p["F"], yerr=p["F_err"], fmt=style[d]["marker"],
                            color=style[d]["color"], label=f"gate, {style[d]['label']}")
            key = "dpd" if d == 1 else "no_dpd"
            if ec.get(key):
                ax.axvline(ec[key], color=style[d]["color"], ls="--", lw=1)
        ax.set(xlabel="time-averaged diffraction efficiency $\\bar\\eta$",
               ylabel="Bell-state fidelity", ylim=(np.nanmin(gate["F"]) - 0.03, 1.0),
               title="fidelity vs efficiency (Fig. 4)")
        ax.legend(fontsize=7)
        _save(plt, fig, stage, outdir, "fig4_fidelity_vs_eta.png", written)

        # Fig. S8: all parity fringes
        if parity:
            keys = sorted(parity)
            nc = 4
            nr = -(-len(keys) // nc)
            fig, axes = plt.subplots(nr, nc, figsize=(3.2 * nc, 2.6 * nr), constrained_layout=True,
                                     squeeze=False)
            for ax, key in zip(axes.flat, keys):
                fringe(ax, key)
            for ax in list(axes.flat)[len(keys):]:
                ax.axis("off")
            _save(plt, fig, stage, outdir, "figS8_parity_fringes.png", written)

        # Fig. S7: time scans with the ideal model
        if time_scans is not None and len(time_scans):
            flags = sorted(time_scans["dpd"].unique(), reverse=True)
            fig, axes = plt.subplots(1, len(flags), figsize=(5 * len(flags), 3.8),
                                     constrained_layout=True, squeeze=False)
            for ax, d in zip(axes.flat, flags):
                ts = time_scans[time_scans["dpd"] == d].sort_values("t_us")
                A = float(ts["A"].iloc[0])
                row = gate[(np.isclose(gate["A"], A)) & (gate["dpd"] == d)]
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
                       title=f"A = {A:g}, {style[d]['label']}")
                ax.legend(fontsize=7)
            _save(plt, fig, stage, outdir, "figS7_time_scans.png", written)
    return written


def plot_parity_only(gate, merged_parity, outdir) -> list[str]:
    """Fig. S8 alone: merged parity fringes of every setting with their fits.

    ``merged_parity`` is the DataFrame of :func:`dpdfit.fits.counts.merge_parity`
    (``A, dpd, phase_rad, n_even, shots``).
    """
    parity = {}
    for (A, d), g in merged_parity.groupby(["A", "dpd"]):
        parity[(float(A), int(d))] = (g["phase_rad"].to_numpy(), g["n_even"].to_numpy(),
                                      g["shots"].to_numpy())
    plt = _pyplot()
    keys = sorted(parity)
    nc = 4
    nr = max(1, -(-len(keys) // nc))
    written: list[str] = []
    with staged_outputs() as stage:
        fig, axes = plt.subplots(nr, nc, figsize=(3.2 * nc, 2.6 * nr), constrained_layout=True,
                                 squeeze=False)
        for ax, key in zip(axes.flat, keys):
            ph, k, n = parity[key]
            row = gate[(np.isclose(gate["A"], key[0])) & (gate["dpd"] == key[1])].iloc[0]
            c = "C0" if key[1] else "C3"
            ax.errorbar(ph, 2 * k / n - 1, yerr=2 * np.sqrt(np.clip(k / n * (1 - k / n), 1e-12, None) / n),
                        fmt="s" if key[1] else "o", mfc="none", color=c, ms=4)
            x = np.linspace(0, 2 * np.pi, 300)
            ax.plot(x, row["contrast"] * np.cos(2 * x + row["phi0"]), color=c)
            ax.set(title=f"A={key[0]:g} {'DPD' if key[1] else 'no DPD'}: C={row['contrast']:.3f}",
                   ylim=(-1.1, 1.1), xlabel="$\\varphi$ (rad)", ylabel="$\\Pi$")
        for ax in list(axes.flat)[len(keys):]:
            ax.axis("off")
        _save(plt, fig, stage, outdir, "figS8_parity_fringes.png", written)
    return written
