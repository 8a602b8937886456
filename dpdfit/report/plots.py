"""Figures (matplotlib).  Plotting stays at the edge of the package.

The figures live in topic modules of :mod:`dpdfit.report`
(:mod:`~dpdfit.report.calibration_plots`: Fig. 1; :mod:`~dpdfit.report.sweep_plots`:
Figs. 2, 5, S4, S6; :mod:`~dpdfit.report.gate_plots`: Figs. 3, 4, S7, S8;
:mod:`~dpdfit.report.stability_plots`: S2, S3; :mod:`~dpdfit.report.diagnosis_plots`;
:mod:`~dpdfit.report.posterior_plots`: the corner plot), with figure making and
PNG writing in :mod:`~dpdfit.report.figure_io`.  This module re-exports every
Figure-returning function, :func:`~dpdfit.report.figure_io.save_figures`, and
the deprecated ``plot_*`` writers under their historical import path.
"""

from __future__ import annotations

from dpdfit.report import *  # noqa: F401,F403  (the Figure-returning functions)
from dpdfit.report import __all__ as _figures
from dpdfit.report.calibration_plots import plot_calibration
from dpdfit.report.diagnosis_plots import plot_diagnosis
from dpdfit.report.gate_plots import plot_gate_figures, plot_parity_only
from dpdfit.report.posterior_plots import plot_corner
from dpdfit.report.stability_plots import plot_stability
from dpdfit.report.sweep_plots import plot_sweep

__all__ = [*_figures, "plot_calibration", "plot_sweep", "plot_gate_figures", "plot_parity_only",
           "plot_stability", "plot_diagnosis", "plot_corner"]
