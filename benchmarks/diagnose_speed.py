"""Wall and CPU time of `dpdfit diagnose` on given campaign folders, one at a time.

    python benchmarks/diagnose_speed.py CAMPAIGN_DIR [CAMPAIGN_DIR ...] [--repeats 1]
                                        [--json PATH]

Each campaign is diagnosed as a user runs it, ``python -m dpdfit diagnose DIR --json``
in a fresh process (interpreter start-up and the campaign's reading included), one
after the other, so that the diagnosis has the machine's cores to itself (it uses them
all, :mod:`dpdfit.core.parallel`).  Per campaign it prints the wall seconds, the CPU
seconds of the process and its workers, the stages' seconds the diagnosis records
(``timing_seconds``), the verdict and the 1-minute load average before the run; then
the median and maximum wall time over the campaigns of each folder and over all.
With ``--repeats N`` every campaign is run N times (round robin) and its median kept.

On a machine shared with other work the wall times are upper bounds; the load average
in each row (and the record's ``machine``) says how busy it was.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

from record import ROOT, add_json_option, summary_line, write_record

STAGES = ("null model", "baseline", "single effects", "more effects", "sizes", "report")


def _children_cpu() -> float:
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def run_once(folder: Path) -> dict:
    """Wall and CPU seconds of one ``dpdfit diagnose`` child process, and what it reports."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + ([env["PYTHONPATH"]]
                                                       if env.get("PYTHONPATH") else []))
    cmd = [sys.executable, "-m", "dpdfit", "diagnose", str(folder), "--json", "--no-progress"]
    load = os.getloadavg()[0]
    cpu0 = _children_cpu()
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    cpu = _children_cpu() - cpu0
    if proc.returncode:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr}")
    d = json.loads(proc.stdout)
    return {"wall": wall, "cpu": cpu, "load": load, "verdict": d.get("verdict"),
            "diagnosis": float(d.get("seconds", float("nan"))),
            "stages": dict(d.get("timing_seconds") or {})}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=summary_line(__doc__))
    parser.add_argument("campaigns", nargs="+", type=Path, help="campaign folders")
    parser.add_argument("--repeats", type=int, default=1,
                        help="runs of each campaign, round robin; the median is kept (1)")
    add_json_option(parser)
    args = parser.parse_args(argv)
    folders = [p.resolve() for p in args.campaigns]
    runs: dict[Path, list[dict]] = {f: [] for f in folders}
    for _ in range(max(args.repeats, 1)):
        for f in folders:
            r = run_once(f)
            runs[f].append(r)
            st = "  ".join(f"{k} {r['stages'].get(k, 0.0):5.1f}" for k in STAGES
                           if k in r["stages"])
            print(f"{f.parent.name}/{f.name}: wall {r['wall']:5.1f} s  cpu {r['cpu']:5.1f} s  "
                  f"load {r['load']:.2f}  verdict {r['verdict']}  [{st}]", flush=True)
    rows = []
    for f in folders:
        rs = runs[f]
        best = sorted(rs, key=lambda r: r["wall"])[(len(rs) - 1) // 2]   # the median run
        row = {"table": "campaigns", "campaign": f"{f.parent.name}/{f.name}",
               "runs": len(rs), "wall [s]": statistics.median(r["wall"] for r in rs),
               "cpu [s]": statistics.median(r["cpu"] for r in rs),
               "diagnosis [s]": best["diagnosis"],
               **{f"{k} [s]": best["stages"].get(k) for k in STAGES},
               "verdict": best["verdict"], "load average, 1 min": best["load"]}
        rows.append(row)
    groups: dict[str, list[dict]] = {}
    for row in rows:
        groups.setdefault(row["campaign"].split("/")[0], []).append(row)
    if len(groups) > 1:
        groups["all"] = list(rows)
    print()
    for name, rs in groups.items():
        walls = [r["wall [s]"] for r in rs]
        cpus = [r["cpu [s]"] for r in rs]
        summ = {"table": "summary", "campaigns": name, "n": len(rs),
                "median wall [s]": statistics.median(walls), "max wall [s]": max(walls),
                "median cpu [s]": statistics.median(cpus), "max cpu [s]": max(cpus),
                "load average, 1 min, median": statistics.median(r["load average, 1 min"]
                                                                 for r in rs)}
        rows.append(summ)
        print(f"{name:>24}: wall median {summ['median wall [s]']:.1f} s, max "
              f"{summ['max wall [s]']:.1f} s; cpu median {summ['median cpu [s]']:.1f} s, max "
              f"{summ['max cpu [s]']:.1f} s ({len(rs)} campaigns)")
    write_record(args.json, "diagnose_speed", rows, description=summary_line(__doc__),
                 notes=["A fresh process per campaign, one at a time: interpreter start-up, "
                        "imports and the campaign's reading included; the diagnosis uses "
                        "every core (BLAS single-threaded).",
                        "cpu: user + system seconds of the process and its worker processes.",
                        "Each row's load average is the machine's 1-minute load before that "
                        "run; on a shared machine the wall times are upper bounds."])


if __name__ == "__main__":
    main()
