"""Speed of the threshold efficiencies' distribution, as `analyze` computes it for a stale table.

    python benchmarks/thresholds_speed.py [--repeats 5] [--compare-with DIR] [--json PATH]

On the bundled campaign's amplitude runs (the posterior of its table run, R034, and the
drift of all runs, as the propagation step makes them; not timed), times
``threshold_distribution`` at a table 30 days old with the step's 1,000 draws: CPU time
of REPEATS calls in a fresh process, their median printed.  With ``--compare-with DIR``,
a checkout of another commit (``git archive COMMIT | tar -x -C DIR``; name DIR after it),
the same runs also in DIR, the two trees taking turns, and the ratio of the medians;
the results of the two trees must be equal (checked).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

from record import ROOT, add_json_option, summary_line, write_record

#: run in a fresh process in a tree: prints the CPU seconds of each call and the result
CHILD = r"""
import json, sys, time
from dpdfit.analyses.propagation import threshold_distribution
from dpdfit.core.defaults import AMPLITUDE_ORDER
from dpdfit.fits.drift import calibration_uncertainty
from dpdfit.recordings.campaign_folder import CampaignFolder
cf = CampaignFolder(sys.argv[1])
unc = calibration_uncertainty(cf.amplitude_runs, AMPLITUDE_ORDER, cf.table_run, seed=1)
times, out = [], None
for _ in range(int(sys.argv[2])):
    c = time.process_time()
    out = threshold_distribution(unc.posterior, stale_days=30.0, draws=1000, drift=unc.drift,
                                 seed=1)
    times.append(time.process_time() - c)
print(json.dumps({"cpu": times, "result": out}))
"""


def run_tree(tree: Path, repeats: int) -> dict:
    """CPU seconds of ``repeats`` calls in a fresh process of ``tree``, and the result."""
    env = {**os.environ, "PYTHONPATH": str(tree)}
    proc = subprocess.run([sys.executable, "-c", CHILD, str(ROOT / "datasets" /
                                                             "synthetic_campaign"), str(repeats)],
                          cwd=tree, env=env, capture_output=True, text=True)
    if proc.returncode:
        raise SystemExit(f"the benchmark failed in {tree}:\n{proc.stderr}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=summary_line(__doc__))
    p.add_argument("--repeats", type=int, default=5, help="calls per tree and turn")
    p.add_argument("--turns", type=int, default=3, help="fresh processes per tree")
    p.add_argument("--compare-with", type=Path, default=None, metavar="DIR")
    add_json_option(p)
    args = p.parse_args(argv)
    trees = {"this tree": ROOT}
    if args.compare_with is not None:
        trees[args.compare_with.name] = args.compare_with.resolve()
    load = [os.getloadavg()[0]]
    times = {name: [] for name in trees}
    results = {}
    for _ in range(args.turns):
        for name, tree in trees.items():
            r = run_tree(tree, args.repeats)
            times[name] += r["cpu"]
            results[name] = r["result"]
    load.append(os.getloadavg()[0])
    same = all(v == results["this tree"] for v in results.values())
    med = {name: statistics.median(t) for name, t in times.items()}
    rows = []
    for name, t in times.items():
        print(f"{name}: median CPU {med[name]:.3f} s over {len(t)} calls "
              f"(min {min(t):.3f}, max {max(t):.3f})")
        rows.append({"tree": name, "median CPU [s]": med[name], "min [s]": min(t),
                     "max [s]": max(t), "calls": len(t)})
    notes = [f"load average {load[0]:.2f} before, {load[1]:.2f} after"]
    if args.compare_with is not None:
        other = args.compare_with.name
        ratio = med[other] / med["this tree"]
        print(f"ratio {other} / this tree: {ratio:.2f}; the same results: {same}")
        rows.append({"tree": f"ratio {other} / this tree", "median CPU [s]": ratio})
        notes.append(f"the two trees' results are equal: {same}")
    write_record(args.json, "thresholds_speed", rows, description=summary_line(__doc__),
                 notes=notes)
    return 0 if same else 1


if __name__ == "__main__":
    raise SystemExit(main())
