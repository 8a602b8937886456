"""Figures (matplotlib, Agg backend).  Plotting stays at the edge of the package.

The figures live in topic modules of :mod:`dpdfit.report`
(:mod:`~dpdfit.report.calibration_plots`: Fig. 1; :mod:`~dpdfit.report.sweep_plots`:
Figs. 2, 5, S4, S6; :mod:`~dpdfit.report.gate_plots`: Figs. 3, 4, S7, S8; ...), with
pyplot access and PNG writing in :mod:`~dpdfit.report.figure_io`.  This module
re-exports them under their historical import path.
"""

from __future__ import annotations

from dpdfit.report.calibration_plots import plot_calibration
from dpdfit.report.figure_io import pyplot as _pyplot  # noqa: F401  (imported by figure modules)
from dpdfit.report.gate_plots import plot_gate_figures, plot_parity_only
from dpdfit.report.sweep_plots import plot_sweep

__all__ = ["plot_calibration", "plot_sweep", "plot_gate_figures", "plot_parity_only"]
