"""An expensive fixture value built once per test run, shared by the run's xdist workers.

Under ``pytest -n 2`` each worker is a process of its own: a session fixture is built
once in every worker that uses it, and a module fixture again in every worker that runs
some of the module's tests.  :func:`built_once` builds the value in the first worker that
asks for it, in a folder of the run's shared temporary folder, under a lock on a file
there, and leaves it pickled beside; a worker that asks later (or waits on the lock
meanwhile) reads it back.  The values are deterministic: whichever worker builds one, it
is the same.  Without xdist, or where files cannot be locked (no ``fcntl``), each process
builds its own, as a plain fixture would.
"""

from __future__ import annotations

import contextlib
import os
import pickle
import shutil
from pathlib import Path

try:
    import fcntl
except ImportError:                       # no POSIX file locks: each worker builds its own
    fcntl = None


@contextlib.contextmanager
def _locked(path: Path):
    with open(path, "w") as fh:
        if fcntl is not None:
            fcntl.flock(fh, fcntl.LOCK_EX)   # released when the file is closed
        yield


def built_once(tmp_path_factory, name: str, build):
    """``build(folder)`` for the whole run: its value, built in ``folder`` (a fresh folder
    named after ``name``) by the first worker that asks, read back by the others.  The
    value must pickle; tests only read it and the files it names."""
    base = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER") and fcntl is not None:
        base = base.parent                    # the run's folder: every worker's basetemp is in it
    folder = base / f"built-once-{name}"
    done = folder / "value.pickle"
    with _locked(base / f"built-once-{name}.lock"):
        if done.exists():
            return pickle.loads(done.read_bytes())
        shutil.rmtree(folder, ignore_errors=True)      # what a build that failed left
        folder.mkdir()
        value = build(folder)
        part = folder / "value.pickle.part"
        part.write_bytes(pickle.dumps(value))
        part.replace(done)                    # whole or absent: never half a pickle
        return value
