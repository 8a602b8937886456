#!/usr/bin/env python
"""How ``dpdfit write-artiq-results --schedule`` answers single-field edits of a campaign's truth.json.

    python benchmarks/truth_config_edits.py [--limit N] [--key PREFIX] [--json PATH]

A small simulated campaign whose truth.json holds a value of every kind its config can
(:func:`dpdfit.simulation.truth_edits.config_of_every_kind`) and a schedule of an
amplitude run, spectra at two amplitudes and a population scan.  Every single-field
edit of its truth.json ``config`` (each key, nested key and first and last list item,
replaced by each value of ``REPLACEMENTS``: text, a list, null, -1, 0, 1e308, NaN,
Infinity, a huge integer, a flag, an object, a list nested deeper) is written in place
of truth.json and the command run on it, each in a child process forked from this one
(the package imported once; memory limited to 4 GiB, 120 s each).  Outcomes:

* ``refused``: exit 2, one ``dpdfit: error:`` line naming truth.json (the contract);
* ``refused elsewhere``: exit 2, one line, not naming truth.json (the recordings it
  generates are not the campaign's, or a schedule point it cannot record);
* ``accepted``: exit 0;
* ``internal error``: the CLI's internal-error line (or out of memory, recursion);
* ``several lines``: stderr held more than one line (RuntimeWarnings);
* ``timeout``: still running after 120 s.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import signal
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

# one BLAS thread (set before numpy is imported): each child is forked from this process
for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")
ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np
import pandas as pd
from record import add_json_option, summary_line, write_record

from dpdfit.cli.main import main
from dpdfit.recordings.schedule import write_schedule
from dpdfit.simulation.campaign import simulate_campaign
from dpdfit.simulation.truth_edits import config_of_every_kind, path_text, single_field_edits

#: a guard against a hang: a refusal takes a fraction of a second, a run a few seconds
TIMEOUT_S = 120.0
#: the memory a child may take: a run of the campaign needs a few hundred MB
MEMORY_LIMIT = 4 * 2**30


def _arguments():
    ap = add_json_option(argparse.ArgumentParser(description=summary_line(__doc__)))
    ap.add_argument("--limit", type=int, default=None,
                    help="only the first N edits (a quick look)")
    ap.add_argument("--key", default="", metavar="PREFIX",
                    help="only the edits of keys starting with PREFIX (e.g. injected)")
    return ap.parse_args()


def _campaign(root: Path) -> tuple[Path, Path]:
    folder = root / "campaign"
    config, effects = config_of_every_kind()
    simulate_campaign(folder, config=config, effects=effects, progress=False)
    grid = np.round(np.linspace(0.0, 1.0, config.cal_points), 10)
    rows = [{"kind": "amplitude_run", "repeat": 1, "point": i, "A": a, "lab_s": 1.0}
            for i, a in enumerate(grid)]
    rows += [{"kind": "spectra", "repeat": 1, "point": k, "A": a, "dpd": d, "lab_s": 5.0}
             for k, (a, d) in enumerate((a, d) for a in (0.3, 0.6) for d in (0, 1))]
    rows += [{"kind": "populations", "repeat": 1, "point": 0, "A": 0.4, "dpd": 0,
              "shots": 200, "lab_s": 2.0}]
    schedule = root / "schedule.csv"
    write_schedule(pd.DataFrame(rows), schedule)
    return folder, schedule


def _run(argv: list[str], err_path: Path) -> tuple[int | None, str, float]:
    """(exit status or None after the timeout, stderr, seconds) of ``main(argv)`` in a
    forked child."""
    t0 = time.monotonic()
    pid = os.fork()
    if pid == 0:                                          # the child
        code = 70
        try:
            resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
            fd = os.open(err_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
            os.dup2(fd, 2)
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, 1)
            code = main(argv)
            sys.stderr.flush()
        finally:
            os._exit(code)
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        if time.monotonic() - t0 > TIMEOUT_S:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            return None, "", time.monotonic() - t0
        time.sleep(0.05)
    code = os.waitstatus_to_exitcode(status)
    return code, err_path.read_text(errors="replace"), time.monotonic() - t0


def _outcome(code, err: str) -> str:
    lines = err.strip().splitlines()
    if code is None:
        return "timeout"
    if any(w in err for w in ("internal error", "out of memory", "recursion")):
        return "internal error"
    if len(lines) > 1:
        return "several lines"
    if code == 0:
        return "accepted"
    if code == 2 and len(lines) == 1 and lines[0].startswith("dpdfit: error:"):
        return "refused" if "truth.json" in lines[0] else "refused elsewhere"
    return f"exit {code}"


def main_() -> None:
    args = _arguments()
    with tempfile.TemporaryDirectory(prefix="truth_edits_") as tmp:
        root = Path(tmp)
        folder, schedule = _campaign(root)
        truth_path = folder / "truth.json"
        truth = json.loads(truth_path.read_text())
        out, err_path = root / "out", root / "stderr.txt"
        argv = ["write-artiq-results", str(folder), str(out), "--schedule", str(schedule)]
        code, err, _ = _run(argv, err_path)
        assert code == 0, err                             # the campaign as simulated
        shutil.rmtree(out)
        edits = [e for e in single_field_edits(truth["config"])
                 if path_text(e[0]).startswith(args.key)][:args.limit]
        rows, tally, t_start = [], Counter(), time.monotonic()
        for path, name, config in edits:
            truth_path.write_text(json.dumps({**truth, "config": config}, indent=2))
            code, err, seconds = _run(argv, err_path)
            shutil.rmtree(out, ignore_errors=True)
            outcome = _outcome(code, err)
            tally[outcome] += 1
            rows.append({"table": "edits", "key": path_text(path), "value": name,
                         "outcome": outcome, "exit": code, "seconds": seconds,
                         "line": (err.strip().splitlines() or [""])[-1][:300]})
            if outcome not in ("refused", "accepted", "refused elsewhere"):
                print(f"{outcome:15s} {path_text(path)} = {name}: {rows[-1]['line'][:160]}",
                      flush=True)
    print(f"\n{len(edits)} single-field edits in {time.monotonic() - t_start:.0f} s:")
    for k, n in tally.most_common():
        print(f"  {k:18s} {n:5d}")
    write_record(args.json, "truth_config_edits",
                 rows + [{"table": "outcomes", "outcome": k, "edits": n}
                         for k, n in tally.most_common()],
                 description=summary_line(__doc__))


if __name__ == "__main__":
    main_()
