"""The steps of ``dpdfit analyze``, one function per analysis, in the order they run.

:data:`PIPELINE` is that order, stated once: each :class:`Step` names its
analysis, its function and the earlier steps whose results it is handed
(results are handed down, never recomputed) and the function that makes its
section of ``summary.json`` from its result.  A step takes the
:class:`~dpdfit.pipeline.context.Context` and those results, records its
output files and status in ``ctx.results``, queues its figures, and returns a
typed result for the steps after it and for the summary (None when skipped);
the summary is rendered once, at the end, from these results:

=============  ==========================================  ==============================
step           module                                      returns
=============  ==========================================  ==============================
calibration    :mod:`.calibration`                          :class:`CalibrationFits`
stability      :mod:`.calibration`                          :class:`StabilityResults`
sweep          :mod:`.spectra`                              :class:`SimulatedSweep`
spectra        :mod:`.spectra`                              :class:`MeasuredSpectra`
traces         :mod:`.spectra`                              :class:`TracesCheck`
gates          :mod:`.gates`                                :class:`GateResults`
propagation    :mod:`.propagation`                          :class:`PropagationResults`
budget         :mod:`.budget`                               the budget (BudgetResult)
diagnosis      :mod:`.diagnosis`                            the diagnosis (Diagnosis)
=============  ==========================================  ==============================
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from .budget import budget_step, budget_summary
from .calibration import (CalibrationFits, StabilityResults, calibration_step,
                          calibration_summary, stability_step, stability_summary)
from .diagnosis import diagnosis_step, diagnosis_summary
from .gates import GateResults, gates_step, gates_summary
from .propagation import PropagationResults, propagation_step, propagation_summary
from .spectra import (MeasuredSpectra, SimulatedSweep, TracesCheck, spectra_step,
                      spectra_summary, sweep_step, sweep_summary, traces_step, traces_summary)

__all__ = ["Step", "PIPELINE", "CalibrationFits", "StabilityResults", "SimulatedSweep",
           "MeasuredSpectra",
           "TracesCheck", "GateResults", "PropagationResults", "calibration_step",
           "stability_step", "sweep_step", "spectra_step", "traces_step", "gates_step",
           "propagation_step", "budget_step", "diagnosis_step"]


@dataclass(frozen=True)
class Step:
    """One analysis of ``analyze``: its name, its function, the steps it is handed and
    the function that makes its ``summary.json`` section from its result."""

    name: str
    run: Callable
    needs: tuple = ()
    summary: Callable | None = None


#: The analyses in the order they run, each with the earlier results it needs.
PIPELINE = (
    Step("calibration", calibration_step, (), calibration_summary),
    Step("stability", stability_step, ("calibration",), stability_summary),
    Step("sweep", sweep_step, ("calibration",), sweep_summary),
    Step("spectra", spectra_step, ("sweep",), spectra_summary),
    Step("traces", traces_step, (), traces_summary),
    Step("gates", gates_step, ("sweep",), gates_summary),
    Step("propagation", propagation_step, ("calibration",), propagation_summary),
    Step("budget", budget_step, ("gates",), budget_summary),
    Step("diagnosis", diagnosis_step, ("calibration",), diagnosis_summary),
)
