"""Wall time of the README's first command, `dpdfit analyze` on the bundled campaign.

    python benchmarks/analyze_wall.py [--repeats 2] [--json PATH]

Runs ``python -m dpdfit analyze datasets/synthetic_campaign -o TMP`` as a user
would (a fresh process, interpreter start-up and every figure written), once
with the diagnosis and once with ``--no-diagnosis``, each REPEATS times,
alternating the two so that a change of load on the machine hits both alike.
Prints the median, minimum and maximum wall time of each.  The README's time
range for the first command is checked against this record by
``tests/docs/test_docs_speed_figures.py``.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from record import ROOT, add_json_option, summary_line, write_record

CAMPAIGN = "datasets/synthetic_campaign"
VARIANTS = (("with the diagnosis", []), ("--no-diagnosis", ["--no-diagnosis"]))


def run_once(extra: list[str]) -> float:
    """Seconds of one ``dpdfit analyze`` child process (it must succeed)."""
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "dpdfit", "analyze", CAMPAIGN, "-o", tmp, *extra]
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
        seconds = time.perf_counter() - t0
    if proc.returncode:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr}")
    return seconds


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=summary_line(__doc__))
    parser.add_argument("--repeats", type=int, default=2,
                        help="runs of each variant (default 2)")
    add_json_option(parser)
    args = parser.parse_args(argv)
    times: dict[str, list[float]] = {name: [] for name, _ in VARIANTS}
    for _ in range(args.repeats):
        for name, extra in VARIANTS:
            times[name].append(run_once(extra))
            print(f"{name}: {times[name][-1]:.1f} s", flush=True)
    rows = []
    for name, _ in VARIANTS:
        ts = times[name]
        rows.append({"command": f"dpdfit analyze {CAMPAIGN} -o DIR"
                                + (" --no-diagnosis" if name == "--no-diagnosis" else ""),
                     "variant": name, "runs": len(ts),
                     "median wall [s]": statistics.median(ts),
                     "min wall [s]": min(ts), "max wall [s]": max(ts)})
    for r in rows:
        print(f"{r['variant']:>20}: median {r['median wall [s]']:.1f} s "
              f"(min {r['min wall [s]']:.1f}, max {r['max wall [s]']:.1f}, {r['runs']} runs)")
    write_record(args.json, "analyze_wall", rows, description=summary_line(__doc__),
                 notes=["A fresh process per run: interpreter start-up, imports, every "
                        "table and figure written to a temporary folder.",
                        "Measured on a shared machine with other jobs running: the times "
                        "are upper bounds for an idle computer of the same kind."])


if __name__ == "__main__":
    main()
