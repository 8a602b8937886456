"""Parallel map of independent engine runs and fits over the machine's cores.

The diagnosis spends most of its time in independent runs of the gate engine
(every setting, every effect step) and independent fits (every effect's forms).
:func:`pmap` spreads them over local processes (``concurrent.futures`` with the
``fork`` context, so nothing but the arguments is pickled) and falls back to a
plain loop when there is one core, when ``fork`` is unavailable, when
``DPDFIT_WORKERS=1``, or inside a worker process (the harness already runs one
diagnosis per core: no nesting).  Results are returned in the order of the
inputs, so the outcome does not depend on the number of workers.

Workers end with their parent: each asks the kernel for ``SIGKILL`` when the
parent dies (Linux ``prctl(PR_SET_PDEATHSIG)``; :func:`die_with_parent`), so a
killed command leaves no worker running; an interrupted one (Ctrl-C) cancels
the jobs not started and terminates its workers before the interrupt goes on.
"""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import signal
import sys
from concurrent.futures import ProcessPoolExecutor

__all__ = ["pmap", "n_workers", "die_with_parent", "terminate_pool"]

_PR_SET_PDEATHSIG = 1


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


def die_with_parent(parent_pid: int | None = None) -> None:
    """Worker initializer: be killed when the parent process dies (Linux; elsewhere a
    no-op), and leave Ctrl-C to the parent (which then terminates the workers).

    ``parent_pid`` is the pid of the process that made the pool: a worker whose parent
    is already another process when it starts (the parent died before ``prctl`` took
    effect) exits at once.  Without it, only re-parenting to pid 1 is recognised; under
    a sub-reaper (containers, some CI runners) an orphan is re-parented elsewhere."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL("libc.so.6", use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
        except OSError:                          # no libc by that name: nothing to ask
            pass
        ppid = os.getppid()                      # the parent died before prctl took effect
        if ppid == 1 or (parent_pid is not None and ppid != parent_pid):
            os._exit(1)


def terminate_pool(ex: ProcessPoolExecutor) -> None:
    """Cancel what has not started and end the pool's workers now (an interrupt)."""
    procs = list((getattr(ex, "_processes", None) or {}).values())
    for p in procs:
        try:
            p.terminate()
        except (OSError, AttributeError):
            pass
    ex.shutdown(wait=False, cancel_futures=True)


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
    ex = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=die_with_parent,
                             initargs=(os.getpid(),))
    try:
        out = list(ex.map(_call, [(fn, a, kw) for a, kw in calls]))
    except BaseException:
        terminate_pool(ex)
        raise
    ex.shutdown()
    return out
