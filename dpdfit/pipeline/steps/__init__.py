"""The steps of ``dpdfit analyze``, one function per analysis, in the order they run.

Each step takes the :class:`~dpdfit.pipeline.context.Context` and the results
of earlier steps it needs (handed down, never recomputed), records its
outputs, summary and status in ``ctx.results``, queues its figures, and
returns what later steps need:

=============  ==========================================  ==========================
step           module                                      hands down
=============  ==========================================  ==========================
calibration    :mod:`.calibration`                          every run's fit
stability      :mod:`.calibration`                          --
sweep          :mod:`.spectra`                              the simulated sweep
spectra        :mod:`.spectra`                              the measured-spectra table
traces         :mod:`.spectra`                              --
gates          :mod:`.gates`                                the gate table
propagation    :mod:`.propagation`                          --
budget         :mod:`.budget`                               --
diagnosis      :mod:`.diagnosis`                            --
=============  ==========================================  ==========================
"""

from .budget import budget_step
from .calibration import CalibrationFits, calibration_step, stability_step
from .diagnosis import diagnosis_step
from .gates import gates_step
from .propagation import propagation_step
from .spectra import spectra_step, sweep_step, traces_step

__all__ = ["CalibrationFits", "calibration_step", "stability_step", "sweep_step", "spectra_step",
           "traces_step", "gates_step", "propagation_step", "budget_step", "diagnosis_step"]
