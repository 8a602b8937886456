"""The diagnosis's engine runs, sized against the memory limit before any is started.

:class:`~dpdfit.analyses.diagnosis.gate_model.GateModel` runs the gate engine
once per setting (and per knob step) in parallel worker processes.  Each run's
state is sized first (:func:`dpdfit.models.gate_sim.setting_size`); the largest,
times the runs that execute at once, must fit the memory limit
(:func:`dpdfit.core.memory.check_memory`), else one
:class:`~dpdfit.errors.InputError` line names the setting, the state and its
likely cause, before a worker is started or an array made.
"""

from __future__ import annotations

from dpdfit.core.parallel import n_workers, pmap
from dpdfit.models import gate_sim

__all__ = ["check_runs_fit", "run_settings"]


def check_runs_fit(calls, labels, folder=None) -> None:
    """InputError if the engine runs ``calls`` (``(args, kwargs)`` of
    :func:`~dpdfit.models.gate_sim.setting_branches`), as many at once as
    :func:`~dpdfit.core.parallel.pmap` runs them, would not fit in memory.

    ``labels[i]`` names run ``i``'s setting ``(A, dpd)``; ``folder`` is the campaign
    folder the message names.
    """
    if not calls:
        return
    sizes = [gate_sim.setting_size(*args, **kw) for args, kw in calls]
    i = max(range(len(sizes)), key=lambda k: sizes[k].nbytes)
    A, dpd = labels[i]
    at_once = min(n_workers(), len(calls))
    what = (f"the gate simulation of setting A={float(A):g}, dpd={int(dpd)} "
            f"({sizes[i].describe()}"
            + (f", {at_once} runs at once)" if at_once > 1 else ")"))
    hint = (sizes[i].cause() + " (gate_rates.csv xi0_khz, time_scans.csv t_us, "
            "campaign.json error_model nbar)")
    gate_sim.check_engine_size(sizes[i], what, file=None if folder is None else str(folder),
                               hint=hint, at_once=at_once)


def run_settings(calls, labels, folder=None) -> list:
    """``pmap(setting_branches, calls)`` after :func:`check_runs_fit`."""
    check_runs_fit(calls, labels, folder)
    return pmap(gate_sim.setting_branches, calls)
