"""Fits of the AOM's static transfer functions: amplitude y(A) and phase phi(A).

* :mod:`~dpdfit.fits.calibration.amplitude` -- ``P(A) = (sum_k b_k A^k)^2``
  fitted to the recorded photodiode power, :class:`AmplitudeCalibration`;
* :mod:`~dpdfit.fits.calibration.phase` -- ``phi(A) = sum_k b_k A^k`` on a
  window of amplitudes, :class:`PhaseCalibration`;
* :mod:`~dpdfit.fits.calibration.combined` -- :class:`Calibration` (the
  content of ``calibration.json``) and :func:`load_calibration`;
* :mod:`~dpdfit.fits.calibration.shared` -- helpers of both fits, including
  :func:`nonmonotone_intervals`.

Error convention (both fits): with given uncertainties the covariance is
absolute; without them sigma is estimated from the residuals and the
covariance scaled by it.  Never a silent rescale: ``sigma_source`` says which.
"""

from dpdfit.fits.calibration.shared import nonmonotone_intervals
from dpdfit.fits.calibration.amplitude import (AmplitudeCalibration, amplitude_order_table,
                                               calibrate_amplitude, fit_amplitude)
from dpdfit.fits.calibration.phase import PhaseCalibration, calibrate_phase, fit_phase
from dpdfit.fits.calibration.combined import Calibration, load_calibration

__all__ = ["AmplitudeCalibration", "PhaseCalibration", "Calibration",
           "fit_amplitude", "fit_phase", "amplitude_order_table",
           "calibrate_amplitude", "calibrate_phase", "load_calibration",
           "nonmonotone_intervals"]
