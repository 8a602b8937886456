"""Running independent jobs (harness injections, external diagnoses) over processes or Dask.

Each job is one campaign simulation and/or diagnosis of tens of seconds, so
the jobs themselves are the parallelism: one job per local process (spawned,
one BLAS thread each), or one per Dask worker (``scheduler="tcp://..."``,
``pip install dpdfit[dask]``).  Results are handed over as the jobs finish.
"""

from __future__ import annotations

import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor, as_completed

from dpdfit.errors import InputError

__all__ = ["run_jobs"]


def run_jobs(fn, jobs: list, workers: int | None, scheduler: str | None, finished) -> None:
    """Call ``finished(fn(job))`` for every job, in the order the jobs finish.

    ``scheduler``: address of a dask.distributed scheduler (the jobs run
    there); else ``workers`` local processes (1: one after the other in this
    process).
    """
    if scheduler:
        try:
            from dask.distributed import Client
            from dask.distributed import as_completed as dask_completed
        except ImportError:
            raise InputError("--scheduler needs dask.distributed: pip install 'dpdfit[dask]'"
                             ) from None
        client = Client(scheduler)
        for f in dask_completed(client.map(fn, jobs, pure=False)):
            finished(f.result())
        client.close()
    elif workers == 1:
        for j in jobs:
            finished(fn(j))
    else:
        # one BLAS thread per worker: the runs are the parallelism.  The
        # variables must be set before numpy loads in the worker, so the
        # workers are spawned (a forked worker inherits the parent's
        # already started BLAS thread pool; on 2 cores two forked workers
        # ran 4 busy threads and each diagnosis took ~4x longer)
        for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
            os.environ.setdefault(var, "1")
        ctx = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as ex:
            for f in as_completed([ex.submit(fn, j) for j in jobs]):
                finished(f.result())
