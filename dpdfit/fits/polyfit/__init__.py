"""Weighted polynomial least squares that stays accurate on ill-conditioned designs.

Fits ``y(x) = sum_j c_j * x**p_j`` for any set of distinct non-negative integer
powers ``p_j`` (e.g. ``1..8`` without a constant, ``0..10`` with one) by
weighted linear least squares, and returns coefficients, their covariance and
the usual goodness-of-fit statistics in a :class:`PolyFitResult`.

* :mod:`~dpdfit.fits.polyfit.fit` -- :func:`polyfit`; its numerical method,
  statistics and error convention are documented there;
* :mod:`~dpdfit.fits.polyfit.inputs` -- :func:`parse_powers` and the input checks;
* :mod:`~dpdfit.fits.polyfit.refine` -- iterative refinement with
  double-double residuals;
* :mod:`~dpdfit.fits.polyfit.double_double` -- vectorised double-double arithmetic;
* :mod:`~dpdfit.fits.polyfit.result` -- :class:`PolyFitResult`.
"""

from dpdfit.fits.polyfit.inputs import parse_powers
from dpdfit.fits.polyfit.result import PolyFitResult
from dpdfit.fits.polyfit.fit import polyfit

__all__ = ["polyfit", "PolyFitResult", "parse_powers"]
