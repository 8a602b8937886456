"""dpdfit: analysis of digitally predistorted trapped-ion entangling-gate experiments.

Data flow one way; each layer (a folder) imports only from the layers before it,
plus :mod:`dpdfit.core` and :mod:`dpdfit.errors` (import-linter contracts in
``pyproject.toml``)::

    recordings   CSV/NPY recordings -> validated tables; the one campaign-folder reader
    fits         polyfit, AOM calibration, counts (population, parity, pooling),
                 tone extraction from traces, posterior, drift, alignment
    models       transfer (AM/PM, inverse, table), waveforms, spectrum,
                 fidelity (S5 estimate), gate_sim (exact gate dynamics)
    analyses     sweep, measured spectra, stability, propagation, budget, diagnosis
    simulation   AOM truth, synthetic campaign simulator, injection harness
    report       figures (matplotlib only here) and the summary
    pipeline     ``analyze``: every analysis on a campaign folder, each fit done once
    cli          the ``dpdfit`` command, a thin layer over this API

The public API is re-exported here (``dpdfit.__all__``).
"""

import logging as _logging

from dpdfit.core.version import __version__  # noqa: E402

from dpdfit.errors import DpdfitError, FitError, InputError, NotInvertibleError  # noqa: E402
from dpdfit.fits.polyfit import PolyFitResult, parse_powers, polyfit  # noqa: E402
from dpdfit.recordings.tables import read_calibration, read_table  # noqa: E402
from dpdfit.fits.calibration import (  # noqa: E402
    AmplitudeCalibration, Calibration, PhaseCalibration, amplitude_order_table,
    calibrate_amplitude, calibrate_phase, fit_amplitude, fit_phase, load_calibration)
from dpdfit.models.transfer import TransferFunction, predistortion_table  # noqa: E402
from dpdfit.models.waveforms import ToneSet, cardioid, sample_grid, synthesize, predistort  # noqa: E402
from dpdfit.models.spectrum import field_tone_powers, simulate_field  # noqa: E402
from dpdfit.fits.tones import trace_tone_powers  # noqa: E402
from dpdfit.recordings.traces import load_trace  # noqa: E402
from dpdfit.recordings.artiq import read_results_file  # noqa: E402
from dpdfit.recordings.campaign_import import import_campaign  # noqa: E402
from dpdfit.analyses.trace_estimate import trace_estimate  # noqa: E402
from dpdfit.models.fidelity import bell_fidelity, estimate, phase_space  # noqa: E402
from dpdfit.models.im_requirements import im_requirements  # noqa: E402
from dpdfit.analyses.sweep import SweepConfig, run_sweep, thresholds  # noqa: E402
from dpdfit.recordings.counts import read_parity, read_populations  # noqa: E402
from dpdfit.fits.counts import (fit_parity, gate_fidelities, merge_parity, pool_populations,  # noqa: E402
                                population_fidelity)
from dpdfit.fits.alignment import align  # noqa: E402
from dpdfit.pipeline.analyze import Analysis, analyze  # noqa: E402

# the library logs, the application decides what to show (the CLI: dpdfit.cli.logs)
_logging.getLogger("dpdfit").addHandler(_logging.NullHandler())

__all__ = [
    "__version__", "DpdfitError", "FitError", "InputError", "NotInvertibleError",
    "PolyFitResult", "parse_powers", "polyfit", "read_calibration", "read_table",
    "AmplitudeCalibration", "Calibration", "PhaseCalibration", "amplitude_order_table",
    "calibrate_amplitude", "calibrate_phase", "fit_amplitude", "fit_phase",
    "load_calibration", "TransferFunction", "predistortion_table",
    "ToneSet", "cardioid", "sample_grid", "synthesize", "predistort", "field_tone_powers",
    "simulate_field", "trace_tone_powers", "trace_estimate", "load_trace", "bell_fidelity",
    "estimate", "im_requirements", "phase_space", "SweepConfig", "run_sweep", "thresholds",
    "fit_parity", "gate_fidelities", "merge_parity", "pool_populations", "population_fidelity",
    "read_parity", "read_populations", "align", "analyze", "Analysis",
    "read_results_file", "import_campaign",
]
