"""``dpdfit ARGV`` run in a forked child of the test process, with a guard against hangs
and runaway memory.

A property test runs a command on hundreds of crafted inputs; some (a FIFO, a device)
could block a reader forever, or make it read until memory runs out (``/dev/zero``, a
sparse file of gigabytes), which must fail the test, not stall it or the machine.  A
fresh interpreter (``python -m dpdfit``) costs a second of imports per case; a child
forked from the test process has dpdfit and its libraries loaded already and starts in
milliseconds.  :func:`run_forked` forks, runs :func:`dpdfit.cli.main.main` in the child
with its standard output and error going to files (so they hold exactly what a user
would see: the command's lines, its log messages and warnings), its address space
bounded (:data:`MEMORY_HEADROOM` beyond what the test process holds), the files it
writes bounded (:data:`FILE_BOUND`: a command copying ``/dev/zero`` is killed by
``SIGXFSZ`` instead of filling the disk; no core dump) and extra environment variables
set, and kills it after ``timeout`` seconds (default the hang guard of
:mod:`tests.helpers.untrusted_campaign`).
"""

from __future__ import annotations

import io
import os
import resource
import signal
import sys
import tempfile
import time
import traceback
from dataclasses import dataclass

from tests.helpers.untrusted_campaign import HANG_GUARD_S

#: the address space a child may take beyond the test process's own: far more than any
#: command needs on the tests' small inputs, far less than an unbounded read would take
MEMORY_HEADROOM = 3 << 29
#: the largest file a child may write: far more than any output of the tests' inputs
FILE_BOUND = 1 << 28
#: the exit status of a child in which an exception escaped ``main`` (a traceback)
ESCAPED = 70

__all__ = ["ESCAPED", "FILE_BOUND", "MEMORY_HEADROOM", "Ran", "run_forked"]


@dataclass(frozen=True)
class Ran:
    """What a forked command did: its exit status (None: killed after the timeout; minus
    the signal's number when a signal ended it), its standard output and error, and the
    seconds it ran."""

    code: int | None
    out: str
    err: str
    seconds: float

    @property
    def hung(self) -> bool:
        return self.code is None


def _address_space() -> int:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmSize:"):
                return int(line.split()[1]) * 1024
    return 0


def _child(argv, env, out_fd, err_fd) -> None:
    """In the child: redirect, bound, run ``main(argv)``; never returns."""
    code = ESCAPED
    try:
        devnull = os.open(os.devnull, os.O_RDONLY)
        os.dup2(devnull, 0)
        os.dup2(out_fd, 1)
        os.dup2(err_fd, 2)
        sys.stdin = open(0, closefd=False)  # noqa: SIM115 - the child never closes them
        sys.stdout = io.TextIOWrapper(open(1, "wb", closefd=False), encoding="utf-8",
                                      errors="backslashreplace", line_buffering=True)
        sys.stderr = io.TextIOWrapper(open(2, "wb", closefd=False), encoding="utf-8",
                                      errors="backslashreplace", line_buffering=True)
        os.environ.update(env or {})
        if sys.platform.startswith("linux"):
            limit = _address_space() + MEMORY_HEADROOM
            resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        resource.setrlimit(resource.RLIMIT_FSIZE, (FILE_BOUND, FILE_BOUND))
        signal.signal(signal.SIGXFSZ, signal.SIG_DFL)    # Python ignores it: a write fails
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
        from dpdfit.cli.main import main
        code = main([str(a) for a in argv])
    except BaseException:  # noqa: BLE001 - what escaped main is the failure being looked for
        traceback.print_exc()
        code = ESCAPED
    finally:
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(code if isinstance(code, int) and 0 <= code < 256 else ESCAPED)


def run_forked(argv, *, env: dict | None = None, timeout: float = HANG_GUARD_S) -> Ran:
    """``dpdfit argv`` in a forked child (module doc), ``env`` added to its environment;
    killed after ``timeout`` seconds (then ``Ran.code`` is None)."""
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        sys.stdout.flush()
        sys.stderr.flush()
        t0 = time.monotonic()
        pid = os.fork()
        if pid == 0:
            _child(argv, env, out.fileno(), err.fileno())
        code, pause = None, 0.001
        while True:
            done, status = os.waitpid(pid, os.WNOHANG)
            if done:
                code = os.waitstatus_to_exitcode(status)
                break
            if time.monotonic() - t0 > timeout:
                os.kill(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
                break
            time.sleep(pause)
            pause = min(2 * pause, 0.05)
        seconds = time.monotonic() - t0
        out.seek(0)
        err.seek(0)
        return Ran(code, out.read().decode("utf-8", "backslashreplace"),
                   err.read().decode("utf-8", "backslashreplace"), seconds)
