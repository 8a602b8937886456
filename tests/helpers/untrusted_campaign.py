"""A campaign folder as a collaborator might send it, and the command line's contract on it.

:func:`small_campaign` copies the bundled campaign's tables (not its 8 MB of traces) into
a test's folder, beside an ``outside/`` folder holding a secret that no command may read.
:func:`tree_state` records a folder tree without following a link or opening anything
but a regular file (a FIFO or ``/dev/zero`` in the tree must not hang the record), so
that a test can check its inputs are unchanged.  :func:`assert_refused_in_process` and
:func:`assert_refused_in_subprocess` run ``dpdfit`` and check one refusal: exit 2, one
``dpdfit: error:`` line on stderr (no traceback, not the internal-error line, nothing of
the secret), the output not written, every input unchanged.  A case that could hang (a
FIFO) runs in a subprocess, whose timeout guards the test; the time of each refusal is
returned, not asserted.
"""

from __future__ import annotations

import hashlib
import io
import os
import re
import shutil
import stat
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import numpy as np
from numpy.lib import format as npy_format

from dpdfit.cli.main import main
from tests.helpers.bundled_data import CAMPAIGN
from tests.helpers.paths import ROOT

#: the bundled campaign's files a small copy holds (its tables, not its traces)
TABLES = ("campaign.json", "calibration_amplitude.csv", "calibration_phase.csv",
          "spectra.csv", "populations.csv", "parity.csv", "gate_rates.csv",
          "time_scans.csv")
#: what the secret outside the campaign holds: no command may print or copy it
SECRET = "SECRET-b7c1e4"
#: a guard against a hang, not a speed test: a refusal takes about a second
HANG_GUARD_S = 60.0


def small_campaign(root: Path) -> Path:
    """``root/campaign``: the bundled campaign's tables; and ``root/outside`` with
    ``secret.csv``, ``secret.json`` and ``secret.toml``, each holding :data:`SECRET`."""
    folder = root / "campaign"
    folder.mkdir()
    for name in TABLES:
        shutil.copy(CAMPAIGN / name, folder / name)
    outside = root / "outside"
    outside.mkdir()
    (outside / "secret.csv").write_text(f"{SECRET},A,dpd\n{SECRET},0.5,0\n")
    (outside / "secret.json").write_text(f'{{"{SECRET}": 1}}\n')
    (outside / "secret.toml").write_text(f'[{SECRET}]\nkey = "{SECRET}"\n')
    return folder


def list_traces(folder: Path, *files: str) -> Path:
    """``folder/traces.csv`` listing ``files`` (one row each, the bundled traces' setting)."""
    rows = "".join(f"{f},0.5,0,1e6,1e5,1840000,20000\n" for f in files)
    path = folder / "traces.csv"
    path.write_text("file,A,dpd,fs,fdet,nu,xi0\n" + rows)
    return path


def declaring_npy_bytes(samples: int) -> bytes:
    """A ``.npy`` whose header declares ``samples`` float64 samples and holds 64 bytes."""
    head = npy_format.header_data_from_array_1_0(np.zeros(1))
    head["shape"] = (int(samples),)
    buf = io.BytesIO()
    npy_format.write_array_header_1_0(buf, head)
    return buf.getvalue() + bytes(64)


def write_declaring_npz(path: Path, samples: int) -> Path:
    """An ``.npz`` of a kilobyte whose ``trace`` declares ``samples`` float64 samples."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("trace.npy", declaring_npy_bytes(samples))
    return path


def tree_state(root: Path) -> dict:
    """Every entry under ``root``: a regular file's SHA-256, a link's target, the type of
    anything else; nothing followed or opened but regular files."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(root, followlinks=False):
        for name in sorted(dirnames + filenames):
            p = Path(dirpath) / name
            st = os.lstat(p)
            rel = str(p.relative_to(root))
            if stat.S_ISLNK(st.st_mode):
                out[rel] = ("link", os.readlink(p))
            elif stat.S_ISREG(st.st_mode):
                out[rel] = ("file", st.st_size, _sha256(p, st.st_size))
            else:
                out[rel] = ("other", stat.S_IFMT(st.st_mode))
    return out


def _sha256(path: Path, size: int) -> str:
    if size > 2**26:                 # a sparse file of gigabytes: its size and start
        with open(path, "rb") as fh:
            return hashlib.sha256(fh.read(2**20)).hexdigest()
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _check_line(code: int, err: str, output: Path | None, needles) -> str:
    lines = err.strip().splitlines()
    assert code == 2, (code, err)
    assert len(lines) == 1 and lines[0].startswith("dpdfit: error:"), err
    line = lines[0]
    assert "internal error" not in line and "Traceback" not in err, line
    assert SECRET not in err, line
    assert "\x1b" not in err and not re.search(r"\bnp\.\w+\(", line), line
    for needle in ([needles] if isinstance(needles, str) else needles):
        assert needle in line, line
    if output is not None:
        assert not os.path.lexists(output), f"{output} was written"
    return line


def assert_refused_in_process(capsys, argv, inputs: Path, output: Path | None = None,
                              needles=()) -> tuple[str, float]:
    """``dpdfit argv`` in this process is refused (module doc); ``inputs``: the tree
    that must stay unchanged, ``output``: a path that must not appear.  Returns the
    error line and the seconds the command took."""
    before = tree_state(inputs)
    capsys.readouterr()
    t0 = time.monotonic()
    code = main([str(a) for a in argv])
    seconds = time.monotonic() - t0
    _, err = capsys.readouterr()
    line = _check_line(code, err, output, needles)
    assert tree_state(inputs) == before
    assert seconds < HANG_GUARD_S, seconds
    return line, seconds


def assert_refused_in_subprocess(argv, inputs: Path, output: Path | None = None,
                                 needles=(), env: dict | None = None,
                                 stdin=None) -> tuple[str, float]:
    """As :func:`assert_refused_in_process`, in a child process that is killed after
    :data:`HANG_GUARD_S` (a hang fails the test instead of blocking it); ``stdin``: the
    child's standard input (e.g. the read end of a pipe held open), else none."""
    before = tree_state(inputs)
    environ = {**os.environ, "PYTHONPATH": str(ROOT), **(env or {})}
    t0 = time.monotonic()
    proc = subprocess.run([sys.executable, "-m", "dpdfit", *map(str, argv)],
                          capture_output=True, text=True, timeout=HANG_GUARD_S,
                          cwd=inputs, env=environ,
                          stdin=subprocess.DEVNULL if stdin is None else stdin)
    seconds = time.monotonic() - t0
    line = _check_line(proc.returncode, proc.stderr, output, needles)
    assert tree_state(inputs) == before
    return line, seconds
