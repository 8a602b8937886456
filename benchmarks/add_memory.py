"""Peak memory and time of `dpdfit add` of 10^6 honest rows, against the tables it reads.

    python benchmarks/add_memory.py [--sizes 16,125000,250000,500000,1000000]
                                    [--repeats 3] [--json PATH]

NEW is a folder with one ``parity.csv`` of ROWS honest rows: parity scans of the 16
analysis phases at the bundled campaign's five gate amplitudes, both flags, ``n_even``
drawn from the fringe near the campaign's fidelity out of 625 shots.  It is added to
the bundled campaign (``datasets/synthetic_campaign``) by the command line, ``python -m
dpdfit add CAMPAIGN NEW -o OUT``, in a child process (interpreter start included), and
the child's maximum resident size is read from its resource usage (``os.wait4``).  Each
size is run REPEATS times; its seconds and peak are the medians.

The tables `dpdfit add` reads are NEW's ``parity.csv`` and the campaign's
``parity.csv`` and ``populations.csv`` (the scan labels continue over both); it copies
the other files without holding them.  The relation checked is "peak <= 2 x the bytes
of those tables + a constant": a straight line fitted to (bytes, peak) over the sizes
gives the measured slope (target at most 2) and constant (its intercept; the peak of
the smallest add, the interpreter, numpy, pandas and dpdfit with the bundled campaign's
own tables, is printed beside it), and each size's (peak - that smallest peak) / bytes
is printed too.
"""

from __future__ import annotations

import argparse
import os
import shutil
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
HEADLINE = "the largest add, and peak = slope x bytes read + constant over the sizes"
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


def _sizes(text: str) -> list[int]:
    sizes = sorted({int(float(x)) for x in text.split(",") if x.strip()})
    if len(sizes) < 2 or sizes[0] < 1:
        raise argparse.ArgumentTypeError("give at least two row counts, each 1 or more")
    return sizes


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sizes", type=_sizes, default=[16, 125_000, 250_000, 500_000, 1_000_000],
                   help="rows of NEW's parity.csv, comma-separated (the largest is the "
                        "headline; default: 16,125000,250000,500000,1000000)")
    p.add_argument("--repeats", type=int, default=3)
    add_json_option(p)
    args = p.parse_args(argv)
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for rows in args.sizes:
            new = write_new(tmp / f"new{rows}", rows)
            read = [new / "parity.csv", CAMPAIGN / "parity.csv", CAMPAIGN / "populations.csv"]
            table_bytes = sum(f.stat().st_size for f in read)
            runs = []
            for i in range(args.repeats):
                out = tmp / f"out{rows}_{i}"
                runs.append(run_add(new, out))
                written = (out / "parity.csv").stat().st_size
                shutil.rmtree(out)
            shutil.rmtree(new)
            results.append({"rows": rows, "bytes": table_bytes, "written": written,
                            "seconds": statistics.median(s for s, _ in runs),
                            "peak": statistics.median(m for _, m in runs),
                            "peaks": [m for _, m in runs]})
    x = np.array([r["bytes"] for r in results], dtype=float)
    y = np.array([r["peak"] for r in results], dtype=float)
    slope, constant = np.polyfit(x, y, 1)
    smallest = results[0]["peak"]
    big = results[-1]
    mib = float(2**20)
    print(f"{'rows':>9s} {'tables read':>12s} {'seconds':>8s} {'peak':>9s} "
          f"{'(peak-smallest)/bytes':>22s}")
    rows_out = []
    for r in results:
        ratio = (r["peak"] - smallest) / r["bytes"]
        print(f"{r['rows']:9d} {r['bytes'] / mib:8.1f} MiB {r['seconds']:8.2f} "
              f"{r['peak'] / mib:5.0f} MiB {ratio:22.2f}")
        rows_out.append({"table": "per size of NEW", "rows added": r["rows"],
                         "tables read [MiB]": r["bytes"] / mib,
                         "merged parity.csv written [MiB]": r["written"] / mib,
                         f"add, median of {args.repeats} [s]": r["seconds"],
                         f"peak resident, median of {args.repeats} [MiB]": r["peak"] / mib,
                         "peak, min [MiB]": min(r["peaks"]) / mib,
                         "peak, max [MiB]": max(r["peaks"]) / mib,
                         "(peak - smallest peak) / bytes read": ratio})
    print(f"dpdfit add of {big['rows']} rows: {big['seconds']:.2f} s, peak resident "
          f"{big['peak'] / mib:.0f} MiB (medians of {args.repeats}); tables read "
          f"{big['bytes'] / mib:.1f} MiB")
    print(f"peak = {slope:.2f} x bytes read + {constant / mib:.0f} MiB (straight line over "
          f"{len(results)} sizes; target slope <= {TARGET_RATIO:g}); the smallest add's "
          f"peak: {smallest / mib:.0f} MiB")
    rows_out += [
        {"table": HEADLINE, "quantity": "rows added", "value": big["rows"]},
        {"table": HEADLINE, "quantity": "bytes of the tables read [MiB]",
         "value": big["bytes"] / mib},
        {"table": HEADLINE, "quantity": f"add, median of {args.repeats} runs [s]",
         "value": big["seconds"]},
        {"table": HEADLINE, "quantity": f"peak resident size, median of {args.repeats} "
         "runs [MiB]", "value": big["peak"] / mib},
        {"table": HEADLINE, "quantity": "slope: peak per byte of the tables read "
         "(straight line over the sizes)", "value": slope, "target": f"<= {TARGET_RATIO:g}"},
        {"table": HEADLINE, "quantity": "constant: the line's intercept [MiB]",
         "value": constant / mib},
        {"table": HEADLINE, "quantity": f"peak of the smallest add ({results[0]['rows']} "
         "rows) [MiB]", "value": smallest / mib},
        {"table": HEADLINE, "quantity": "(peak - smallest peak) / bytes read, largest add",
         "value": (big["peak"] - smallest) / big["bytes"], "target": f"<= {TARGET_RATIO:g}"},
    ]
    write_record(args.json, "add_memory", rows_out, description=summary_line(__doc__),
                 notes=["seconds: wall time of the child process, interpreter start "
                        "included; the machine (2 cores) was shared with other work",
                        "peak: the child's maximum resident size (ru_maxrss)"])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
