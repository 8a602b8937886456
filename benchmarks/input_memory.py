#!/usr/bin/env python
"""Peak memory of the commands that read a campaign, against the bytes of the files they read.

    python benchmarks/input_memory.py                          # campaigns 1x, 4x, 16x
    python benchmarks/input_memory.py --sizes 1,4 --json benchmarks/input_memory.json

Each command runs in a fresh child process (``dpdfit.cli.main.main``), which reports its
own peak resident memory (``ru_maxrss``, imports included).  The campaigns are
``benchmarks/scale.py``'s k x the bundled one (denser calibration runs, a finer spectra
grid, more gate scans; cached under ``/tmp/dpdfit-scale``).  The bytes a command reads are
the campaign folder's files (tables, ``campaign.json``, the raw traces).

A straight line through the points, ``peak = constant + slope x bytes``, gives the two
numbers the target speaks of: the slope (target: at most 2) and the constant (what a
command costs on an empty campaign: the interpreter, numpy, scipy, pandas and the
package).

Commands: ``analyze --no-diagnosis --no-plots`` (every table, every analysis but the
diagnosis) and ``add`` (the campaign with a copy of its own counts as new recordings).
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from record import add_json_option, summary_line, write_record
from scale import build_campaign

_CHILD = """
import json, resource, sys
from dpdfit.cli.main import main
code = main(json.loads(sys.argv[1]))
print(json.dumps({"code": code, "maxrss_kib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss}))
"""


def _run(argv: list[str]) -> dict:
    out = subprocess.run([sys.executable, "-c", _CHILD, json.dumps(argv)], capture_output=True,
                         text=True, check=False)
    try:
        res = json.loads(out.stdout.strip().splitlines()[-1])
    except (IndexError, json.JSONDecodeError):
        raise SystemExit(f"child failed: {out.stderr[-2000:]}") from None
    if res["code"] != 0:
        raise SystemExit(f"{' '.join(argv)}: exit {res['code']}: {out.stderr[-2000:]}")
    return res


def folder_bytes(folder: Path) -> int:
    """Bytes of the files a command reads of a campaign folder."""
    return sum(f.stat().st_size for f in folder.rglob("*") if f.is_file())


def _new_counts(folder: Path, tmp: Path) -> Path:
    """New recordings for ``add``: the campaign's own population and parity scans again."""
    new = tmp / "new"
    new.mkdir()
    for name in ("populations.csv", "parity.csv"):
        shutil.copy(folder / name, new / name)
    return new


def measure(sizes: list[int], cache: Path) -> list[dict]:
    rows = []
    for k in sizes:
        folder = build_campaign(k, cache)
        size = folder_bytes(folder)
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            runs = {
                "analyze": ["analyze", str(folder), "-o", str(tmp / "results"), "--no-diagnosis",
                            "--no-plots", "--no-progress"],
            }
            new = _new_counts(folder, tmp)
            runs["add"] = ["add", str(folder), str(new), "-o", str(tmp / "added")]
            for command, argv in runs.items():
                res = _run(argv)
                read = size + (folder_bytes(new) if command == "add" else 0)
                rows.append({"command": command, "size": f"{k}x", "input [MiB]": read / 2**20,
                             "peak [MiB]": res["maxrss_kib"] / 1024})
                print(f"{command:8s} {k:3d}x  input {read / 2**20:8.1f} MiB  "
                      f"peak {res['maxrss_kib'] / 1024:8.1f} MiB", flush=True)
    return rows


def fit(rows: list[dict]) -> list[dict]:
    """``peak = constant + slope x input`` per command (least squares over the sizes)."""
    out = []
    for command in dict.fromkeys(r["command"] for r in rows):
        x = np.array([r["input [MiB]"] for r in rows if r["command"] == command])
        y = np.array([r["peak [MiB]"] for r in rows if r["command"] == command])
        slope, constant = np.polyfit(x, y, 1) if len(x) > 1 else (np.nan, y[0])
        out.append({"command": command, "slope": float(slope), "constant [MiB]": float(constant)})
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=summary_line(__doc__))
    ap.add_argument("--sizes", default="1,4,16", help="campaign multiples (default 1,4,16)")
    ap.add_argument("--cache", default="/tmp/dpdfit-scale", help="generated campaigns")
    add_json_option(ap)
    a = ap.parse_args(argv)
    cache = Path(a.cache)
    cache.mkdir(parents=True, exist_ok=True)
    rows = measure([int(s) for s in a.sizes.split(",") if s], cache)
    lines = fit(rows)
    for f in lines:
        print(f"{f['command']:8s} peak = {f['constant [MiB]']:.0f} MiB + {f['slope']:.2f} x input")
    write_record(a.json, "input_memory", [{"table": "runs", **r} for r in rows]
                 + [{"table": "fit", **f} for f in lines], description=summary_line(__doc__),
                 notes=["peak: the child's ru_maxrss (imports included); one run per point"])


if __name__ == "__main__":
    main()
