"""Parallel map of independent engine runs over the machine's cores.

The diagnosis spends most of its time in independent runs of the gate engine
(every setting, every effect step).  :func:`pmap` spreads them over local
processes (``concurrent.futures`` with the ``fork`` context, so nothing but
the arguments is pickled) and falls back to a plain loop when there is one
core, when ``fork`` is unavailable, when ``DPDFIT_WORKERS=1``, or inside a
worker process (the harness already runs one diagnosis per core: no nesting).
Results are returned in the order of the inputs, so the outcome does not
depend on the number of workers.
"""

from __future__ import annotations

import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor

__all__ = ["pmap", "n_workers"]


def n_workers() -> int:
    """Processes to use: ``DPDFIT_WORKERS`` if set, else the cores (1 inside a worker)."""
    env = os.environ.get("DPDFIT_WORKERS")
    if env:
        return max(1, int(env))
    if multiprocessing.parent_process() is not None:
        return 1
    if "fork" not in multiprocessing.get_all_start_methods():
        return 1
    return max(1, min(os.cpu_count() or 1, 8))


def _call(args):
    fn, a, kw = args
    return fn(*a, **kw)


def pmap(fn, calls, workers: int | None = None) -> list:
    """``[fn(*a, **kw) for a, kw in calls]``, in parallel when worthwhile."""
    calls = list(calls)
    workers = n_workers() if workers is None else workers
    workers = min(workers, len(calls))
    if workers <= 1:
        return [fn(*a, **kw) for a, kw in calls]
    ctx = multiprocessing.get_context("fork")
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as ex:
        return list(ex.map(_call, [(fn, a, kw) for a, kw in calls]))
