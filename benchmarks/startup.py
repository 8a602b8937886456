"""Start-up time of dpdfit: `import dpdfit` and `dpdfit --help` in fresh processes.

    python benchmarks/startup.py [--runs 15] [--compare-with DIR] [--json PATH]

Times RUNS fresh interpreters of each command, as a user meets them:
``python -c "pass"`` (the interpreter alone), ``python -c "import dpdfit"`` and
``python -m dpdfit --help``, run from the repository's root so that its ``dpdfit`` is the
one imported.  The commands take turns, so that a change of load on the machine hits
them alike.  Prints the median, minimum and maximum wall time of each, and the median's
ratio to its target (0.5 s for the import, 0.6 s for the help), and the load average
before and after.  With ``--compare-with DIR``, a checkout of another commit (``git
archive COMMIT | tar -x -C DIR``; name DIR after it), the same commands also run from
DIR in the same turns: the start-up before a change, measured under the same load.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from record import ROOT, add_json_option, summary_line, write_record

#: what is timed: name -> (arguments of python, target seconds of its median or None)
COMMANDS = {
    "python -c 'pass'": (["-c", "pass"], None),
    "python -c 'import dpdfit'": (["-c", "import dpdfit"], 0.5),
    "python -m dpdfit --help": (["-m", "dpdfit", "--help"], 0.6),
}


def run_once(args: list[str], tree: Path) -> float:
    """Seconds of one fresh ``python ARGS`` in ``tree`` (it must succeed)."""
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, *args], cwd=tree, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if proc.returncode:
        raise SystemExit(f"python {' '.join(args)} in {tree} failed ({proc.returncode}):\n"
                         f"{proc.stderr}")
    return seconds


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=summary_line(__doc__))
    parser.add_argument("--runs", type=int, default=15,
                        help="fresh processes of each command (default 15)")
    parser.add_argument("--compare-with", metavar="DIR", type=Path, default=None,
                        help="also time the commands in DIR, a checkout of another commit")
    add_json_option(parser)
    args = parser.parse_args(argv)
    trees = {"this tree": ROOT}
    if args.compare_with is not None:
        trees[args.compare_with.resolve().name] = args.compare_with.resolve()
    # the interpreter alone is the same in every tree
    cases = [(tree, name) for tree in trees for name in COMMANDS
             if COMMANDS[name][1] is not None or tree == "this tree"]
    load_before = os.getloadavg()
    for tree, name in cases:                       # warm the file cache: not timed
        run_once(COMMANDS[name][0], trees[tree])
    times: dict[tuple, list[float]] = {case: [] for case in cases}
    for _ in range(args.runs):
        for tree, name in cases:
            times[tree, name].append(run_once(COMMANDS[name][0], trees[tree]))
    load_after = os.getloadavg()
    rows = []
    print(f"{'command':28s} {'tree':>16s} {'median':>8s} {'min':>7s} {'max':>7s}  target")
    for tree, name in cases:
        ts, target = times[tree, name], COMMANDS[name][1]
        med = statistics.median(ts)
        row = {"command": name, "tree": tree, "runs": len(ts), "median [s]": med,
               "min [s]": min(ts), "max [s]": max(ts)}
        if target is not None:
            row.update({"target [s]": f"<= {target:g}", "median / target": med / target})
        rows.append(row)
        print(f"{name:28s} {tree[:16]:>16s} {med:8.3f} {min(ts):7.3f} {max(ts):7.3f}  "
              + (f"<= {target:g} s (ratio {med / target:.2f})" if target else ""))
    load = (f"load average (1, 5, 15 min) {', '.join(f'{x:.2f}' for x in load_before)} "
            f"before, {', '.join(f'{x:.2f}' for x in load_after)} after")
    print(load)
    notes = [f"{args.runs} fresh processes of each command, taking turns; {load}"]
    if args.compare_with is not None:
        notes.append(f"tree {args.compare_with.resolve().name}: {args.compare_with}")
    write_record(args.json, "startup", rows, description=summary_line(__doc__), notes=notes)


if __name__ == "__main__":
    main()
