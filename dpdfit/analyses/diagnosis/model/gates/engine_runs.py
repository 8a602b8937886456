"""The diagnosis's engine runs, sized against the memory limit before any is started.

:class:`~dpdfit.analyses.diagnosis.model.gates.gate_model.GateModel` runs the gate engine
once per setting (and per knob step) in parallel worker processes.  Each run's
state is sized first (:func:`dpdfit.models.gate_sim.setting_size`); the largest,
times the runs that execute at once, must fit the memory limit
(:func:`dpdfit.core.memory.check_memory`), else one
:class:`~dpdfit.errors.InputError` line names the setting, the state and its
likely cause, before a worker is started or an array made.

Each preparation branch of a run is its own integration
(:func:`~dpdfit.models.gate_sim.setting_branches`), so the runs are spread over the
workers branch by branch, the costliest first, and every branch's outcome is kept
(:data:`RUN_CACHE_ENTRIES`, least recently used dropped) under everything it depends
on: the engine is deterministic, and one diagnosis asks for the same field again and
again (a tone-side fit carried to the gates under both phase-sign conventions, the
forward selections and the refits from it, the baseline's other sign first with its
two-ion branch only, then with all).
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from dpdfit.core.parallel import n_workers, pmap
from dpdfit.models import gate_sim

__all__ = ["check_runs_fit", "run_settings", "RUN_CACHE_ENTRIES", "clear_run_cache"]

#: branch outcomes kept (about a kilobyte each)
RUN_CACHE_ENTRIES = 4096
#: the branches of :func:`~dpdfit.models.gate_sim.setting_branches`: (name, ions)
_BRANCHES = (("2", 2), ("1", 1), ("2_01", 2), ("1_1", 1))

_CACHE: OrderedDict = OrderedDict()


def clear_run_cache() -> None:
    """Forget every kept branch outcome."""
    _CACHE.clear()


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


def _frozen(v):
    """A hashable, exact stand-in for an argument of the engine."""
    if isinstance(v, np.ndarray):
        return ("array", v.dtype.str, v.shape, v.tobytes())
    if isinstance(v, (list, tuple)):
        return ("seq", tuple(_frozen(x) for x in v))
    if isinstance(v, dict):
        return ("dict", tuple(sorted((k, _frozen(x)) for k, x in v.items())))
    if isinstance(v, (np.generic, float, int, bool)) or v is None or isinstance(v, str):
        return (type(v).__name__, v.item() if isinstance(v, np.generic) else v)
    raise TypeError(f"engine argument of type {type(v).__name__} cannot be keyed")


def _branch_names(kw: dict) -> list:
    spectator, flip = kw.get("spectator", True), kw.get("flip", True)
    return (["2"] + (["1"] if spectator else []) + (["2_01"] if flip else [])
            + (["1_1"] if spectator and flip else []))


def _key(args, kw, name) -> tuple:
    rest = {k: v for k, v in kw.items() if k not in ("spectator", "flip", "branches")}
    return (name, _frozen(tuple(np.asarray(a) if isinstance(a, (list, tuple)) else a
                                for a in args)), _frozen(rest))


def run_settings(calls, labels, folder=None) -> list:
    """``[setting_branches(*a, **kw) for a, kw in calls]`` after :func:`check_runs_fit`:
    the branches not kept from an earlier call run over the cores, the two-ion ones
    first (module doc).  The dicts share their arrays with the cache: read-only."""
    check_runs_fit(calls, labels, folder)
    wanted, jobs = [], {}
    for args, kw in calls:
        keys = []
        for name in _branch_names(kw):
            k = _key(args, kw, name)
            keys.append(k)
            if k not in _CACHE and k not in jobs:
                jobs[k] = (args, {**kw, "branches": (name,)})
        wanted.append(keys)
    ions = dict(_BRANCHES)
    # the costliest first (a two-ion branch integrates four times the state of a
    # one-ion branch), so that the cores stay busy to the end
    todo = sorted(jobs.items(), key=lambda kv: -ions[kv[0][0]])
    if todo:
        # compiled here once, so that the forked workers inherit it
        gate_sim.load_compiled_kernel()
    done = dict(zip((k for k, _ in todo), pmap(gate_sim.setting_branches,
                                                [j for _, j in todo])))
    for k, r in done.items():
        for v in r.values():
            if isinstance(v, np.ndarray):
                v.flags.writeable = False
        _CACHE[k] = r
    out = []
    for keys in wanted:
        run = {}
        for k in keys:
            r = done.get(k)
            if r is None:
                r = _CACHE[k]
                _CACHE.move_to_end(k)
            run.update(r)
        out.append(run)
    while len(_CACHE) > RUN_CACHE_ENTRIES:
        _CACHE.popitem(last=False)
    return out
