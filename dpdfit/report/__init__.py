"""Figures and written summaries (matplotlib is imported here only, on first use).

Every figure has a function that draws it and returns a
:class:`matplotlib.figure.Figure`; each takes ``ax=`` (one panel) or ``fig=``
(several panels) to draw into the caller's axes or figure, e.g. in a notebook::

    from dpdfit.report import calibration_figure, sweep_figures, save_figures
    fig = calibration_figure(cal)                 # shown inline in Jupyter
    figs = sweep_figures(sweep)                   # {file stem: Figure}
    save_figures(figs, "figures")                 # figures/fig2_spectral.png, ...

No matplotlib backend is chosen by the library.  New figures are plain
:class:`~matplotlib.figure.Figure` objects, not managed by pyplot (nothing to
close, no duplicate display): in Jupyter a returned Figure is shown once
matplotlib's inline support is on (``%matplotlib inline``, or after any pyplot
figure); ``plt.show()`` does not know them -- draw into your own
``plt.subplots()`` with ``ax=``/``fig=`` for that.
"""

from dpdfit.report.calibration_plots import (amplitude_calibration_figure, calibration_figure,
                                             calibration_figures, phase_calibration_figure,
                                             predistortion_figure)
from dpdfit.report.comparison_plots import comparison_figure
from dpdfit.report.diagnosis_plots import DIAGNOSIS_DPI, diagnosis_figure, diagnosis_figures
from dpdfit.report.figure_io import DPI, save_figures
from dpdfit.report.gate_plots import (fidelity_vs_efficiency_figure, fidelity_vs_rate_figure,
                                      gate_figures, merged_parity_figure, parity_fringes_figure,
                                      time_scans_figure)
from dpdfit.report.posterior_plots import CORNER_DPI, corner_figure
from dpdfit.report.stability_plots import envelope_figure, stability_figure, stability_figures
from dpdfit.report.sweep_plots import (infidelity_vs_efficiency_figure, phase_space_figure,
                                       spectral_figure, spectral_supplement_figure, sweep_figures)

__all__ = [
    "amplitude_calibration_figure", "phase_calibration_figure", "predistortion_figure",
    "calibration_figure", "calibration_figures",
    "spectral_figure", "spectral_supplement_figure", "infidelity_vs_efficiency_figure",
    "phase_space_figure", "sweep_figures",
    "fidelity_vs_rate_figure", "fidelity_vs_efficiency_figure", "parity_fringes_figure",
    "time_scans_figure", "gate_figures", "merged_parity_figure",
    "stability_figure", "envelope_figure", "stability_figures",
    "diagnosis_figure", "diagnosis_figures", "comparison_figure",
    "corner_figure",
    "save_figures", "DPI", "DIAGNOSIS_DPI", "CORNER_DPI",
]
