"""Worker processes end when the command that started them is killed or interrupted."""

import os
import queue
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from tests.helpers.paths import ROOT


# a parent that starts a pool of busy workers (as the diagnosis does) and reports them
_SCRIPT = r"""
import os, sys, time
from dpdfit.core.parallel import pmap
def busy(i):
    print("worker", os.getpid(), flush=True)
    t = time.time()
    while time.time() - t < 300:
        pass
pmap(busy, [((i,), {}) for i in range(2)], workers=2)
"""


def _children(pid: int) -> list:
    out = subprocess.run(["ps", "-o", "pid=", "--ppid", str(pid)], capture_output=True,
                         text=True).stdout
    return [int(x) for x in out.split()]


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:                       # a zombie is gone for our purpose
        state = Path(f"/proc/{pid}/stat").read_text().split()[2]
    except OSError:
        return False
    return state != "Z"


def _state(pid: int) -> str:
    try:
        f = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return f"{pid}: state {f[0]}, cpu ticks {int(f[11]) + int(f[12])}"
    except (OSError, IndexError, ValueError):
        return f"{pid}: gone"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGINT, signal.SIGTERM])
def test_pool_workers_do_not_outlive_their_parent(sig):
    # the command as a terminal starts it: Ctrl-C not ignored (a test runner started in
    # the background, as CI may be, hands its children an ignored SIGINT)
    p = subprocess.Popen([sys.executable, "-c", _SCRIPT], cwd=ROOT, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True,
                         env={**os.environ, "DPDFIT_WORKERS": "2"},
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    # The workers are the parent's children (a forked pool has no other helper
    # process).  They are found in the process table rather than by what they
    # print: in the loaded test run a worker's line once never arrived although
    # both workers existed, and what the test is about is the processes.
    lines = queue.Queue()
    threading.Thread(target=lambda: [lines.put(x) for x in p.stdout], daemon=True).start()
    deadline = time.time() + 180          # generous: a loaded machine schedules forks late
    printed = []
    while time.time() < deadline:
        try:
            printed.append(lines.get(timeout=0.5))
        except queue.Empty:
            pass
        # both have started their job (its first act is to print), or have been
        # running for a while: the initializer that ties them to the parent is done
        if len(_children(p.pid)) == 2 and (len(printed) == 2 or
                                           time.time() > deadline - 170):
            break
    workers = _children(p.pid)
    if len(workers) < 2:
        p.kill()
        pytest.fail(f"{len(workers)} of 2 workers started ({[_state(w) for w in workers]}); "
                    f"printed {printed}; stderr: {p.stderr.read()[-2000:]}")
    p.send_signal(sig)
    p.wait(timeout=30)
    deadline = time.time() + 10
    while any(_alive(w) for w in workers) and time.time() < deadline:
        time.sleep(0.1)
    alive = [_state(w) for w in workers if _alive(w)]
    assert not alive, f"workers outlived the command: {alive}; printed {printed}"
