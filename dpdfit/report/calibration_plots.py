"""Fig. 1 of the paper: the AOM calibration.

(a) amplitude data, fit, confidence band and the linearised response under
DPD (:func:`amplitude_calibration_figure`); (b) phase data, fit and band
(:func:`phase_calibration_figure`); (c) the predistortion function
(:func:`predistortion_figure`); all side by side (:func:`calibration_figure`).
:func:`calibration_figures` draws the set ``dpdfit analyze`` writes.
"""

from __future__ import annotations

import numpy as np

from dpdfit.fits.calibration import AmplitudeCalibration, Calibration, PhaseCalibration
from dpdfit.models.transfer import TransferFunction
from dpdfit.recordings.calibration_runs import CalibrationData
from dpdfit.report.figure_io import panel_grid, single_axes

__all__ = ["amplitude_calibration_figure", "phase_calibration_figure", "predistortion_figure",
           "calibration_figure", "calibration_figures"]

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


def _inversion(cal: Calibration):
    """``(transfer function, None)``, or ``(transfer function, reason)`` when not invertible."""
    tf = TransferFunction.from_calibration(cal)
    try:
        tf.invertibility()
    except Exception as exc:  # NotInvertibleError: show it, do not fail the plot
        return tf, str(exc)
    return tf, None


def _panels(cal: Calibration, amp_data, phase_data) -> dict:
    """``{file stem: draw(ax)}`` of the panels of Fig. 1 ((b) only with a phase calibration)."""
    amp = cal.amplitude
    tf, inv_err = _inversion(cal)
    panels = {"fig1a_amplitude": lambda ax: _amplitude_panel(ax, amp, tf, inv_err, amp_data)}
    if cal.phase is not None:
        panels["fig1b_phase"] = lambda ax: _phase_panel(ax, cal.phase, phase_data)
    panels["fig1c_predistortion"] = lambda ax: _predistortion_panel(ax, tf, amp.A_corr, inv_err)
    return panels


def _one_panel(draw, ax):
    fig, ax = single_axes(ax, (4.2, 3.4))
    draw(ax)
    return fig


def amplitude_calibration_figure(cal: Calibration, amp_data: CalibrationData | None = None, *,
                                 ax=None):
    """Fig. 1(a): amplitude data (signed sqrt of the powers), the fit with its 2-sigma band
    and the response with DPD; returns the Figure (drawn into ``ax`` when given)."""
    return _one_panel(_panels(cal, amp_data, None)["fig1a_amplitude"], ax)


def phase_calibration_figure(cal: Calibration, phase_data: CalibrationData | None = None, *,
                             ax=None):
    """Fig. 1(b): phase data inside and outside the fit window, the fit with its 2-sigma band.

    ``cal`` must have a phase calibration; returns the Figure (drawn into ``ax`` when given).
    """
    if cal.phase is None:
        raise ValueError("the calibration has no phase part")
    return _one_panel(lambda a: _phase_panel(a, cal.phase, phase_data), ax)


def predistortion_figure(cal: Calibration, *, ax=None):
    """Fig. 1(c): the predistortion function f_AM^-1, or the reason it does not exist;
    returns the Figure (drawn into ``ax`` when given)."""
    return _one_panel(_panels(cal, None, None)["fig1c_predistortion"], ax)


def calibration_figure(cal: Calibration, amp_data: CalibrationData | None = None,
                       phase_data: CalibrationData | None = None, *, fig=None):
    """Fig. 1: panels (a), (b) (if a phase calibration is present) and (c) side by side.

    Drawn into ``fig`` (an empty Figure or SubFigure) when given; returns the Figure.
    """
    panels = list(_panels(cal, amp_data, phase_data).values())
    fig, axes = panel_grid(fig, 1, len(panels), (4.2 * len(panels), 3.6))
    for ax, draw in zip(axes.flat, panels):
        draw(ax)
    return fig


def calibration_figures(cal: Calibration, amp_data: CalibrationData | None = None,
                        phase_data: CalibrationData | None = None) -> dict:
    """Fig. 1 as ``dpdfit analyze`` writes it: ``{file stem: Figure}``.

    ``fig1a_amplitude``, ``fig1b_phase`` (if a phase calibration is present),
    ``fig1c_predistortion`` (each panel alone) and ``fig1_calibration`` (all
    panels).  Panel (c) shows the reason in its place when the fit is not invertible.
    """
    figs = {name: _one_panel(draw, None)
            for name, draw in _panels(cal, amp_data, phase_data).items()}
    figs["fig1_calibration"] = calibration_figure(cal, amp_data, phase_data)
    return figs
