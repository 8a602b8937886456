"""Stability of the amplitude and phase calibrations over time (Supplement S2, Figs. S1-S2).

A multi-run calibration file (``run`` and ``timestamp`` columns, one block of
points per run) is fitted run by run with :mod:`dpdfit.fits.calibration`; the
scalar tracked is ``y(1) = A_corr`` (amplitude) or ``phi(1)`` (phase, fitted on
``A_min <= A <= 1``).  :func:`stability` returns

* the time series (run, timestamp, day, value, per-run standard error);
* ``mean``, ``std`` (sample standard deviation over runs, ddof = 1),
  ``relative_std = std / |mean|``, ``n_runs``, ``span_days`` -- the numbers
  quoted in Supplement S2 (0.5655, 0.0091, 1.6 % for the amplitude);
* a drift test (straight line of the value versus time in days), see
  :func:`drift_test` for the error model;
* an Allan deviation for irregularly spaced runs, see :func:`allan_deviation`;
* the family of curves y(A) (or phi(A)) of all runs on a grid with the mean
  curve and the +/- 1 sigma envelope (Fig. S2).

Caveat (stated in the report): the drift test treats the run-to-run
deviations about the line as independent.  A slowly wandering response
(correlated over several runs) makes the trend error optimistic; the lag-1
autocorrelation of the residuals is reported so that this can be judged.

Modules: :mod:`.timeseries` (drift test, Allan deviation), :mod:`.result`
(:class:`StabilityResult`), :mod:`.runs` (reading and fitting the runs,
:func:`stability`).  Figures S2, S3: :mod:`dpdfit.report.stability_plots`;
the command: :mod:`dpdfit.cli.stability`.
"""

from .result import StabilityResult
from .runs import missing_stability_columns, stability
from .timeseries import allan_deviation, drift_test

__all__ = ["StabilityResult", "stability", "drift_test", "allan_deviation",
           "missing_stability_columns"]
