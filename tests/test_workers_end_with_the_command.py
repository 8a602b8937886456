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

ROOT = Path(__file__).resolve().parents[1]

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


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGINT, signal.SIGTERM])
def test_pool_workers_do_not_outlive_their_parent(sig):
    p = subprocess.Popen([sys.executable, "-c", _SCRIPT], cwd=ROOT, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True,
                         env={**os.environ, "DPDFIT_WORKERS": "2"})
    workers = []
    # generous: under a loaded test run a forked worker can take long to be scheduled
    deadline = time.time() + 180
    lines = queue.Queue()
    threading.Thread(target=lambda: [lines.put(x) for x in p.stdout], daemon=True).start()
    while len(workers) < 2 and time.time() < deadline:
        try:
            line = lines.get(timeout=1.0)
        except queue.Empty:
            continue
        if line.startswith("worker"):
            workers.append(int(line.split()[1]))
    if len(workers) < 2:
        children = _children(p.pid)
        p.kill()
        pytest.fail(f"{len(workers)} of 2 workers started; children {children}; "
                    f"stderr: {p.stderr.read()[-2000:]}")
    p.send_signal(sig)
    p.wait(timeout=30)
    deadline = time.time() + 10
    while any(_alive(w) for w in workers) and time.time() < deadline:
        time.sleep(0.1)
    assert not any(_alive(w) for w in workers), "a worker outlived the command"
