"""dpdfit: analysis of digitally predistorted trapped-ion entangling-gate experiments.

Data flow (one module per stage)::

    tables       recordings (CSV) -> validated tables
    polyfit      stable weighted polynomial least squares
    calibration  AOM amplitude y(A) and phase phi(A) fits with uncertainties
    transfer     forward AM/PM model, inverse f_AM^-1, predistortion table
    plots        figures (matplotlib, at the edge)
    cli          the ``dpdfit`` command, a thin layer over this API

``aom_truth`` is a physical AOM model used to generate synthetic recordings.
"""

__version__ = "0.1.0"

from .errors import DpdfitError, FitError, InputError, NotInvertibleError  # noqa: E402
from .polyfit import PolyFitResult, parse_powers, polyfit  # noqa: E402
from .tables import read_calibration, read_table  # noqa: E402
from .calibration import (  # noqa: E402
    AmplitudeCalibration, Calibration, PhaseCalibration, amplitude_order_table,
    calibrate_amplitude, calibrate_phase, fit_amplitude, fit_phase, load_calibration)
from .transfer import TransferFunction, predistortion_table  # noqa: E402

__all__ = [
    "__version__", "DpdfitError", "FitError", "InputError", "NotInvertibleError",
    "PolyFitResult", "parse_powers", "polyfit", "read_calibration", "read_table",
    "AmplitudeCalibration", "Calibration", "PhaseCalibration", "amplitude_order_table",
    "calibrate_amplitude", "calibrate_phase", "fit_amplitude", "fit_phase",
    "load_calibration", "TransferFunction", "predistortion_table",
]
