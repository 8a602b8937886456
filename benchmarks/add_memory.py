"""Peak memory and time of `dpdfit add` of 10^6 honest rows, against the tables it reads.

    python benchmarks/add_memory.py [--rows 1000000] [--repeats 1] [--json PATH]

NEW is a folder with one ``parity.csv`` of ROWS honest rows: parity scans of the 16
analysis phases at the bundled campaign's five gate amplitudes, both flags, ``n_even``
drawn from the fringe near the campaign's fidelity out of 625 shots.  It is added to
the bundled campaign (``datasets/synthetic_campaign``) by the command line, ``python -m
dpdfit add CAMPAIGN NEW -o OUT``, in a child process (interpreter start included), and
the child's maximum resident size is read from its resource usage (``os.wait4``).  The
same is done for a tiny NEW (one scan, 16 rows): its peak is the constant (the
interpreter, numpy, pandas and dpdfit, the bundled campaign's own tables).

The tables `dpdfit add` reads are NEW's ``parity.csv`` and the campaign's
``parity.csv`` and ``populations.csv`` (the scan labels continue over both); it copies
the other files without holding them.  Printed and recorded: the seconds (median over
REPEATS), the peaks, the bytes of those tables, and the ratio (peak - constant) / bytes,
whose target is at most 2.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from dpdfit.core.defaults import ERROR_MODEL
from record import ROOT, add_json_option, summary_line, write_record

CAMPAIGN = ROOT / "datasets" / "synthetic_campaign"
AMPLITUDES = (0.4, 0.5, 0.6, 0.7, 0.8)
TARGET_RATIO = 2.0
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join(
    [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])}


def write_new(folder: Path, rows: int) -> Path:
    """NEW: ``parity.csv`` with ``rows`` rows (module doc), written in blocks."""
    folder.mkdir(parents=True)
    phases = np.asarray(ERROR_MODEL.analysis_phases(), dtype=float)
    p_even = 0.5 + 0.48 * np.cos(2 * phases)
    rng = np.random.default_rng(2)
    scans = -(-rows // len(phases))
    with open(folder / "parity.csv", "w", encoding="utf-8") as fh:
        fh.write("A,dpd,scan,phase_rad,n_even,shots\n")
        written, block = 0, 4096
        for s0 in range(0, scans, block):
            ks = np.arange(s0, min(scans, s0 + block))
            n_even = rng.binomial(625, np.tile(p_even, (len(ks), 1)))
            lines = []
            for k, counts in zip(ks, n_even):
                a, dpd, label = AMPLITUDES[k % 5], (k // 5) % 2, k // 10 + 1
                for ph, n in zip(phases, counts):
                    if written == rows:
                        break
                    lines.append(f"{a:g},{dpd},{label},{ph:.10g},{n},625\n")
                    written += 1
            fh.write("".join(lines))
    return folder


def run_add(new: Path, out: Path) -> tuple[float, int]:
    """``python -m dpdfit add CAMPAIGN NEW -o OUT`` in a child: (seconds, max RSS bytes)."""
    cmd = [sys.executable, "-m", "dpdfit", "add", str(CAMPAIGN), str(new), "-o", str(out)]
    t = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=ENV,
                            cwd=out.parent)
    _, status, usage = os.wait4(proc.pid, 0)
    seconds = time.perf_counter() - t
    proc.returncode = os.waitstatus_to_exitcode(status)
    err = proc.stderr.read().decode(errors="replace")
    proc.stderr.close()
    if proc.returncode != 0:
        raise SystemExit(f"dpdfit add failed ({proc.returncode}): {err.strip()}")
    return seconds, usage.ru_maxrss * 1024            # Linux: kilobytes


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--rows", type=int, default=1_000_000)
    p.add_argument("--repeats", type=int, default=1)
    add_json_option(p)
    args = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        tiny, big = write_new(tmp / "tiny", 16), write_new(tmp / "big", args.rows)
        read = [big / "parity.csv", CAMPAIGN / "parity.csv", CAMPAIGN / "populations.csv"]
        table_bytes = sum(f.stat().st_size for f in read)
        _, constant = run_add(tiny, tmp / "out_tiny")
        runs = [run_add(big, tmp / f"out{i}") for i in range(args.repeats)]
        out_bytes = (tmp / "out0" / "parity.csv").stat().st_size
    seconds = statistics.median(s for s, _ in runs)
    peak = max(m for _, m in runs)
    ratio = (peak - constant) / table_bytes
    mb = 1e6
    print(f"NEW: {args.rows} rows of parity.csv; tables read {table_bytes / mb:.1f} MB "
          f"(the merged parity.csv written: {out_bytes / mb:.1f} MB)")
    print(f"dpdfit add: median {seconds:.2f} s over {args.repeats} run(s); peak resident "
          f"{peak / mb:.0f} MB; the constant (a 16-row add) {constant / mb:.0f} MB")
    print(f"(peak - constant) / bytes of the tables read: {ratio:.2f} (target <= "
          f"{TARGET_RATIO:g})")
    rows = [
        {"quantity": "rows added", "value": args.rows},
        {"quantity": "bytes of the tables read [MB]", "value": table_bytes / mb},
        {"quantity": "merged parity.csv written [MB]", "value": out_bytes / mb},
        {"quantity": f"add, median of {args.repeats} run(s) [s]", "value": seconds},
        {"quantity": "peak resident size [MB]", "value": peak / mb},
        {"quantity": "constant: peak of a 16-row add [MB]", "value": constant / mb},
        {"quantity": "(peak - constant) / bytes of the tables read", "value": ratio,
         "target": f"<= {TARGET_RATIO:g}"},
    ]
    write_record(args.json, "add_memory", rows, description=summary_line(__doc__))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
