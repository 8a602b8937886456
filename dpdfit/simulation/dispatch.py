"""Running independent jobs (harness injections, external diagnoses) over processes or Dask.

Each job is one campaign simulation and/or diagnosis of tens of seconds, so
the jobs themselves are the parallelism: one job per local process (spawned,
one BLAS thread each), or one per Dask worker (``scheduler="tcp://..."``,
``pip install dpdfit[dask]``).  Results are handed over as the jobs finish.

A job that raises, or whose worker dies, is handed to ``failed(job, error)``
when given (else its error is raised): Dask first runs the job again on
another worker (``distributed.scheduler.allowed-failures``, 3 by default) and
gives up with ``KilledWorker``; a local process that dies breaks the pool, and
every job not finished by then is handed to ``failed``.  No job is dropped.
"""

from __future__ import annotations

import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor, as_completed

from dpdfit.core.parallel import die_with_parent, terminate_pool
from dpdfit.errors import InputError

__all__ = ["run_jobs"]


def run_jobs(fn, jobs: list, workers: int | None, scheduler: str | None, finished,
             failed=None) -> None:
    """Call ``finished(fn(job))`` for every job, in the order the jobs finish.

    ``scheduler``: address of a dask.distributed scheduler (the jobs run
    there); else ``workers`` local processes (1: one after the other in this
    process).  ``failed(job, error)``: called for each job that raised or
    whose worker died (after Dask's own retries); without it the first such
    error is raised.
    """
    def result(f, job):
        try:
            r = f.result() if f is not None else fn(job)
        except Exception as e:                    # noqa: BLE001 - handed over, not lost
            if failed is None:
                raise
            failed(job, e)
        else:
            finished(r)

    if scheduler:
        try:
            from dask.distributed import Client
            from dask.distributed import as_completed as dask_completed
        except ImportError:
            raise InputError("--scheduler needs dask.distributed: pip install 'dpdfit[dask]'"
                             ) from None
        with Client(scheduler) as client:
            futures = client.map(fn, jobs, pure=False)
            job_of = {f.key: j for f, j in zip(futures, jobs)}
            for f in dask_completed(futures):
                result(f, job_of[f.key])
    elif workers == 1:
        for j in jobs:
            result(None, j)
    else:
        # one BLAS thread per worker: the runs are the parallelism.  The
        # variables must be set before numpy loads in the worker, so the
        # workers are spawned (a forked worker inherits the parent's
        # already started BLAS thread pool; on 2 cores two forked workers
        # ran 4 busy threads and each diagnosis took ~4x longer)
        for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
            os.environ.setdefault(var, "1")
        ctx = multiprocessing.get_context("spawn")
        # workers die with this process (killed or interrupted: none is left running)
        ex = ProcessPoolExecutor(max_workers=workers, mp_context=ctx,
                                 initializer=die_with_parent, initargs=(os.getpid(),))
        try:
            job_of = {ex.submit(fn, j): j for j in jobs}
            for f in as_completed(job_of):
                result(f, job_of[f])
        except BaseException:
            terminate_pool(ex)
            raise
        ex.shutdown()
