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

The public API is re-exported here, lazily (``dpdfit.__all__``).
"""

import logging as _logging
from importlib import import_module as _import_module
from typing import TYPE_CHECKING

from dpdfit.core.version import __version__

# The public API is re-exported lazily (PEP 562): ``import dpdfit`` loads none of it, so a
# command starts without paying for scipy.stats, pandas or the diagnosis; a name's module
# is imported the first time the name is used (``dpdfit.polyfit``, ``from dpdfit import
# polyfit``).  Hand-written rather than the lazy_loader package: a dict and two functions,
# with no dependency and no stub file to keep in step.  Type checkers and IDEs read the
# imports below; tests/package (test_architecture, test_startup_imports) check that they
# name ``__all__`` and that each name's value is the object they name.
#: public name -> the module that defines it
_LAZY = {
    **dict.fromkeys(("DpdfitError", "FitError", "InputError", "NotInvertibleError"),
                    "dpdfit.errors"),
    **dict.fromkeys(("PolyFitResult", "parse_powers", "polyfit"), "dpdfit.fits.polyfit"),
    **dict.fromkeys(("read_calibration", "read_table"), "dpdfit.recordings.tables"),
    **dict.fromkeys(("AmplitudeCalibration", "Calibration", "PhaseCalibration",
                     "amplitude_order_table", "calibrate_amplitude", "calibrate_phase",
                     "fit_amplitude", "fit_phase", "load_calibration"), "dpdfit.fits.calibration"),
    **dict.fromkeys(("TransferFunction", "predistortion_table"), "dpdfit.models.transfer"),
    **dict.fromkeys(("ToneSet", "cardioid", "sample_grid", "synthesize", "predistort"),
                    "dpdfit.models.waveforms"),
    **dict.fromkeys(("field_tone_powers", "simulate_field"), "dpdfit.models.spectrum"),
    "trace_tone_powers": "dpdfit.fits.tones",
    "load_trace": "dpdfit.recordings.traces",
    "read_results_file": "dpdfit.recordings.artiq",
    "import_campaign": "dpdfit.recordings.campaign_import",
    "trace_estimate": "dpdfit.analyses.trace_estimate",
    **dict.fromkeys(("bell_fidelity", "estimate", "phase_space"), "dpdfit.models.fidelity"),
    "im_requirements": "dpdfit.models.im_requirements",
    **dict.fromkeys(("SweepConfig", "run_sweep", "thresholds"), "dpdfit.analyses.sweep"),
    **dict.fromkeys(("read_parity", "read_populations"), "dpdfit.recordings.counts"),
    **dict.fromkeys(("fit_parity", "gate_fidelities", "merge_parity", "pool_populations",
                     "population_fidelity"), "dpdfit.fits.counts"),
    "align": "dpdfit.fits.alignment",
    **dict.fromkeys(("Analysis", "analyze"), "dpdfit.pipeline.analyze"),
}

if TYPE_CHECKING:  # what the table above imports when a name is first used
    from dpdfit.errors import DpdfitError, FitError, InputError, NotInvertibleError
    from dpdfit.fits.polyfit import PolyFitResult, parse_powers, polyfit
    from dpdfit.recordings.tables import read_calibration, read_table
    from dpdfit.fits.calibration import (
        AmplitudeCalibration, Calibration, PhaseCalibration, amplitude_order_table,
        calibrate_amplitude, calibrate_phase, fit_amplitude, fit_phase, load_calibration)
    from dpdfit.models.transfer import TransferFunction, predistortion_table
    from dpdfit.models.waveforms import ToneSet, cardioid, sample_grid, synthesize, predistort
    from dpdfit.models.spectrum import field_tone_powers, simulate_field
    from dpdfit.fits.tones import trace_tone_powers
    from dpdfit.recordings.traces import load_trace
    from dpdfit.recordings.artiq import read_results_file
    from dpdfit.recordings.campaign_import import import_campaign
    from dpdfit.analyses.trace_estimate import trace_estimate
    from dpdfit.models.fidelity import bell_fidelity, estimate, phase_space
    from dpdfit.models.im_requirements import im_requirements
    from dpdfit.analyses.sweep import SweepConfig, run_sweep, thresholds
    from dpdfit.recordings.counts import read_parity, read_populations
    from dpdfit.fits.counts import (fit_parity, gate_fidelities, merge_parity, pool_populations,
                                    population_fidelity)
    from dpdfit.fits.alignment import align
    from dpdfit.pipeline.analyze import Analysis, analyze


def __getattr__(name: str):
    """A public name's value, its module imported on first use (then kept in the module)."""
    try:
        module = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    value = getattr(_import_module(module), name)
    globals()[name] = value          # later uses are plain attribute look-ups
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


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
