"""Fig. 1 of the paper: the AOM calibration.

:func:`plot_calibration` draws (a) amplitude data, fit, confidence band and the
linearised response under DPD; (b) phase data, fit and band; (c) the
predistortion function -- each panel alone and all side by side.
"""

from __future__ import annotations

import os

import numpy as np

from dpdfit.fits.calibration import AmplitudeCalibration, Calibration, PhaseCalibration
from dpdfit.models.transfer import TransferFunction
from dpdfit.recordings.outputs import staged_outputs
from dpdfit.recordings.tables import CalibrationData
from dpdfit.report.figure_io import pyplot, save_png

__all__ = ["plot_calibration"]

#: amplitude grid of the drawn curves
_GRID = np.linspace(0, 1, 501)


def _amplitude_panel(ax, amp: AmplitudeCalibration, tf: TransferFunction, inv_err,
                     amp_data: CalibrationData | None):
    """(a) signed sqrt of the powers, the fit with its 2-sigma band, the response with DPD."""
    A, Ac = _GRID, amp.A_corr
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


def _phase_panel(ax, ph: PhaseCalibration, phase_data: CalibrationData | None):
    """(b) phase data inside and outside the fit window, the fit with its 2-sigma band."""
    A = _GRID
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


def _predistortion_panel(ax, tf: TransferFunction, A_corr: float, inv_err):
    """(c) the inverse f_AM^-1, or the reason it does not exist."""
    A = _GRID
    if inv_err is not None:
        ax.text(0.5, 0.5, "not invertible:\n" + inv_err[:120], ha="center", va="center",
                fontsize=7, wrap=True, transform=ax.transAxes)
        ax.set_title("(c) predistortion")
        return
    ax.plot(A, tf.inverse_am(A), color="orange", label="$f_{AM}^{-1}$ (clamped beyond $A_{corr}$)")
    ax.plot(A, A, color="0.6", ls=":", lw=1, label="$y=A$")
    ax.axvline(A_corr, color="k", ls="--", lw=1)
    ax.set(xlabel="target optical amplitude", ylabel="RF amplitude $A$", xlim=(0, 1),
           ylim=(0, 1.05), title="(c) predistortion")
    ax.legend(fontsize=7, loc="lower right")


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
    plt = pyplot()
    amp = cal.amplitude
    tf = TransferFunction.from_calibration(cal)
    try:
        tf.invertibility()
        inv_err = None
    except Exception as exc:  # NotInvertibleError: show it, do not fail the plot
        inv_err = str(exc)

    panels = [("fig1a_amplitude.png", lambda ax: _amplitude_panel(ax, amp, tf, inv_err, amp_data))]
    if cal.phase is not None:
        panels.append(("fig1b_phase.png", lambda ax: _phase_panel(ax, cal.phase, phase_data)))
    panels.append(("fig1c_predistortion.png",
                   lambda ax: _predistortion_panel(ax, tf, amp.A_corr, inv_err)))
    written = []
    with staged_outputs() as stage:
        for name, draw in panels:
            fig, ax = plt.subplots(figsize=(4.2, 3.4), constrained_layout=True)
            draw(ax)
            written.append(save_png(fig, stage, outdir, name))
        fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.6),
                                 constrained_layout=True)
        for ax, (_, draw) in zip(np.atleast_1d(axes), panels):
            draw(ax)
        written.append(save_png(fig, stage, outdir, "fig1_calibration.png"))
    return written
