"""How `dpdfit import` scales to a month of ARTIQ results: 1,000 to 10,000 files.

    python benchmarks/import_scale.py [--sizes 1000 3000 10000] [--repeats 3]
        [--repeats-largest 1] [--cache /tmp/dpdfit-import-scale] [--no-cli] [--json PATH]

The lab: one amplitude calibration (201 amplitudes) and N - 1 parity scans of 16
phases (axis in turns; arguments ``amplitude`` and ``dpd``), written as ARTIQ does
(``results/<YYYY-MM-DD>/<HH>/<rid:09d>-<Class>.h5``, by
:func:`dpdfit.simulation.artiq_results_file.write_results_file`) at start times spread
evenly, with jitter, over 30 days (720 hour folders: about 14 files per hour
folder at N = 10,000).  The parity scans record *per-point counts* (integer
channels ``n_even`` and ``shots``, 16 values each) rather than per-shot outcome
arrays (``benchmarks/import_speed.py`` measures those): a file is then ~20 kB,
mostly HDF5 structure, and the 10,000-file tree stays under ~250 MB (the sizes
are printed and recorded).  import_speed's writer is not reused: it writes
per-shot arrays one minute apart, not a month of counts.

The trees are cached under ``--cache`` (one folder per N, reused when its
``tree.json`` matches this generator; generation time is printed and recorded,
also when the cache was used).  Before timing, every file is read once, so the
page cache is warm for every run alike.

Each measurement runs in a fresh child process (this script with ``--child``):
``import_campaign(mapping, progress=False)`` then ``.write(folder)`` -- the whole
of ``dpdfit import`` but the interpreter's start.  Timed runs: wall time of the
import, of the write and of both (median over ``--repeats`` children; at the
largest N ``--repeats-largest``, 1 by default), and the child's peak resident
size (``ru_maxrss``, includes the interpreter and imported libraries).  A
separate child per N runs the same under :mod:`tracemalloc` (started after the
libraries are imported) for the peak of Python/numpy allocations, and the memory
still held when ``import_campaign`` returns (the tables, the provenance) next to
the tables' own size (pandas ``memory_usage(deep=True)``).  Finally, at the
largest N, ``python -m dpdfit import MAP -o DIR --no-progress`` is timed once
(interpreter start included; rusage of that child by ``os.wait4``).
The default run takes ~10-15 min on a 2-core machine, generation included.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
# the checkout's dpdfit, not an installed copy (children too: PYTHONPATH)
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join(
    [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])}

from record import add_json_option, summary_line, write_record  # noqa: E402
#: bump when the files written change (invalidates cached trees)
GENERATOR = "import_scale/1"
SEED = 20261127
T0 = datetime(2026, 10, 1, tzinfo=timezone.utc).timestamp()
DAYS = 30
PHASES = 16
SHOTS = 100
MAPPING = '''\
[[calibration_amplitude]]
files = "results/*/*/*-AmplitudeCalibration.h5"
[calibration_amplitude.columns]
A = { axis = "amplitude" }
power = { channel = "pd_power" }
run = { run = "rid", format = "R{:03d}" }
timestamp = { run = "start_time" }

[[parity]]
files = "results/*/*/*-ParityScan.h5"
[parity.columns]
A = { argument = "amplitude" }
dpd = { argument = "dpd" }
phase_rad = { axis = "phase", unit = "turn" }
n_even = { channel = "n_even" }
shots = { channel = "shots" }
'''
MB = 1e6


# ----------------------------------------------------------------------------- the trees
def write_tree(lab: Path, n_files: int) -> None:
    """One amplitude calibration and ``n_files - 1`` parity scans over 30 days."""
    from dpdfit.simulation.artiq_results_file import (axis, channel, ndscan_datasets,
                                                      write_results_file)
    rng = np.random.default_rng(SEED)
    a = np.linspace(0, 1, 201)
    write_results_file(lab, 1, "AmplitudeCalibration", T0 - 600.0, ndscan_datasets(
        1, "lab.AmplitudeCalibration", [axis("amplitude", a)], {"pd_power": channel(a ** 2)}))
    turns = np.arange(PHASES) / PHASES
    gap = DAYS * 86400.0 / max(n_files - 1, 1)
    shots = np.full(PHASES, SHOTS, dtype=np.int64)
    for k in range(n_files - 1):
        rid = k + 2
        amp = round(0.1 + 0.1 * (k % 8), 1)
        p_even = 0.5 * (1 + 0.8 * np.cos(2 * np.pi * (2 * turns + 0.05 * amp)))
        n_even = rng.binomial(SHOTS, p_even).astype(np.int64)
        start = T0 + k * gap + rng.uniform(0, 0.5 * gap)
        write_results_file(lab, rid, "ParityScan", start, ndscan_datasets(
            rid, "lab.ParityScan", [axis("phase", turns, "turn")],
            {"n_even": channel(n_even), "shots": channel(shots)}),
            arguments={"amplitude": amp, "dpd": k % 2})
    (lab / "map.toml").write_text(MAPPING)


def tree(cache: Path, n_files: int) -> dict:
    """The cached tree of ``n_files`` files (written if missing or stale): its description."""
    lab = cache / f"n{n_files}"
    info_file = lab / "tree.json"
    want = {"generator": GENERATOR, "files": n_files, "seed": SEED, "days": DAYS,
            "phases": PHASES, "shots": SHOTS}
    if info_file.exists():
        info = json.loads(info_file.read_text())
        if {k: info.get(k) for k in want} == want:
            print(f"N = {n_files}: cached tree {lab} (generated in "
                  f"{info['generation_s']:.0f} s)", flush=True)
            return {**info, "lab": str(lab), "cached": True}
    if lab.exists():
        shutil.rmtree(lab)
    lab.mkdir(parents=True)
    t = time.perf_counter()
    write_tree(lab, n_files)
    gen = time.perf_counter() - t
    files = sorted(lab.glob("results/*/*/*.h5"))
    hours = {f.parent for f in files}
    info = {**want, "generation_s": gen, "bytes": sum(f.stat().st_size for f in files),
            "hour_folders": len(hours), "day_folders": len({h.parent for h in hours})}
    info_file.write_text(json.dumps(info, indent=1) + "\n")     # last: marks it complete
    print(f"N = {n_files}: generated {lab} in {gen:.0f} s ({info['bytes'] / MB:.0f} MB, "
          f"{info['hour_folders']} hour folders)", flush=True)
    return {**info, "lab": str(lab), "cached": False}


def warm(lab: Path) -> None:
    """Read every results file once (page cache warm for every timed run alike)."""
    for f in lab.glob("results/*/*/*.h5"):
        f.read_bytes()


# ----------------------------------------------------------------------------- children
def child(mode: str, lab: str) -> None:
    """One import + write in this process; prints one JSON line."""
    import tracemalloc

    from dpdfit.recordings.campaign_import import import_campaign
    import pandas  # noqa: F401  (imported before tracing, as the import module does)

    if mode == "trace":
        tracemalloc.start()
    with tempfile.TemporaryDirectory(prefix="import-scale-") as tmp:
        t0 = time.perf_counter()
        imported = import_campaign(Path(lab) / "map.toml", progress=False)
        t1 = time.perf_counter()
        held = tracemalloc.get_traced_memory()[0] if mode == "trace" else None
        imported.write(Path(tmp) / "campaign")
        t2 = time.perf_counter()
        peak = tracemalloc.get_traced_memory()[1] if mode == "trace" else None
    tracemalloc.stop()
    out = {"import_s": t1 - t0, "write_s": t2 - t1, "total_s": t2 - t0,
           "rows": int(sum(len(df) for df in imported.tables.values())),
           "table_bytes": int(sum(df.memory_usage(deep=True).sum()
                                  for df in imported.tables.values())),
           "sources": len(imported.meta["imported"]["sources"]),
           "maxrss_bytes": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
           "held_bytes": held, "peak_bytes": peak,
           "dpdfit": str(Path(sys.modules["dpdfit"].__file__).parent)}
    print(json.dumps(out))


def run_child(mode: str, lab: str) -> dict:
    p = subprocess.run([sys.executable, __file__, "--child", mode, lab], capture_output=True,
                       text=True, cwd=str(ROOT / "benchmarks"), env=ENV)
    if p.returncode:
        sys.stderr.write(p.stderr)
        raise SystemExit(f"child ({mode}, {lab}) failed")
    return json.loads(p.stdout.strip().splitlines()[-1])


def run_cli(lab: str) -> dict:
    """``python -m dpdfit import`` once: wall time and the child's rusage."""
    with tempfile.TemporaryDirectory(prefix="import-scale-cli-") as tmp:
        cmd = [sys.executable, "-m", "dpdfit", "import", str(Path(lab) / "map.toml"),
               "-o", str(Path(tmp) / "campaign"), "--no-progress"]
        with open(Path(tmp) / "stderr.txt", "w+b") as err:
            t = time.perf_counter()
            p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err, cwd=tmp, env=ENV)
            _, status, usage = os.wait4(p.pid, 0)
            wall = time.perf_counter() - t
            p.returncode = os.waitstatus_to_exitcode(status)
            if p.returncode:
                err.seek(0)
                sys.stderr.write(err.read().decode(errors="replace"))
                raise SystemExit("dpdfit import failed")
    return {"wall_s": wall, "maxrss_bytes": usage.ru_maxrss * 1024,
            "user_s": usage.ru_utime, "system_s": usage.ru_stime}


# ----------------------------------------------------------------------------- main
def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sizes", type=int, nargs="+", default=[1000, 3000, 10000])
    p.add_argument("--repeats", type=int, default=3, help="timed children per N (3)")
    p.add_argument("--repeats-largest", type=int, default=1,
                   help="timed children at the largest N (1)")
    p.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir())
                   / "dpdfit-import-scale")
    p.add_argument("--no-cli", action="store_true", help="skip timing python -m dpdfit import")
    p.add_argument("--child", nargs=2, metavar=("MODE", "LAB"), help=argparse.SUPPRESS)
    add_json_option(p)
    args = p.parse_args(argv)
    if args.child:
        child(*args.child)
        return 0

    started = time.perf_counter()
    sizes = sorted(set(args.sizes))
    trees = {n: tree(args.cache, n) for n in sizes}
    res = {}
    for n in sizes:
        lab = trees[n]["lab"]
        warm(Path(lab))
        reps = args.repeats_largest if n == sizes[-1] else args.repeats
        timed = [run_child("time", lab) for _ in range(reps)]
        traced = run_child("trace", lab)
        res[n] = {"timed": timed, "traced": traced, "repeats": reps,
                  "total_s": statistics.median(r["total_s"] for r in timed),
                  "import_s": statistics.median(r["import_s"] for r in timed),
                  "write_s": statistics.median(r["write_s"] for r in timed),
                  "maxrss_bytes": max(r["maxrss_bytes"] for r in timed)}
        r = res[n]
        if traced["dpdfit"] != str(ROOT / "dpdfit"):
            raise SystemExit(f"the children imported {traced['dpdfit']}, not this checkout")
        print(f"N = {n}: import + write {r['total_s']:.1f} s (median of {reps}; import "
              f"{r['import_s']:.1f}, write {r['write_s']:.1f}), "
              f"{1e3 * r['total_s'] / n:.2f} s per 1000 files, ru_maxrss "
              f"{r['maxrss_bytes'] / MB:.0f} MB, tracemalloc peak "
              f"{traced['peak_bytes'] / MB:.0f} MB (held after import "
              f"{traced['held_bytes'] / MB:.0f} MB, tables {traced['table_bytes'] / MB:.1f} MB)",
              flush=True)
    cli = None
    if not args.no_cli:
        cli = run_cli(trees[sizes[-1]]["lab"])
        print(f"N = {sizes[-1]}: python -m dpdfit import --no-progress {cli['wall_s']:.1f} s, "
              f"ru_maxrss {cli['maxrss_bytes'] / MB:.0f} MB", flush=True)

    rows = []
    for n in sizes:
        r, info = res[n], trees[n]
        rows.append({
            "table": "time",
            "results files": n,
            "tree [MB]": info["bytes"] / MB,
            "mean file [kB]": info["bytes"] / n / 1e3,
            "hour folders": info["hour_folders"],
            "generation [s]": info["generation_s"],
            "timed runs": r["repeats"],
            "import + write, median [s]": r["total_s"],
            "min [s]": min(x["total_s"] for x in r["timed"]),
            "max [s]": max(x["total_s"] for x in r["timed"]),
            "of which import [s]": r["import_s"],
            "of which write [s]": r["write_s"],
            "per 1000 files [s]": 1e3 * r["total_s"] / n,
        })
    for n in sizes:
        r, tr = res[n], res[n]["traced"]
        rows.append({
            "table": "memory",
            "results files": n,
            "table rows": tr["rows"],
            "ru_maxrss [MB]": r["maxrss_bytes"] / MB,
            "tracemalloc peak [MB]": tr["peak_bytes"] / MB,
            "held after import [MB]": tr["held_bytes"] / MB,
            "tables (deep) [MB]": tr["table_bytes"] / MB,
            "peak / tables": tr["peak_bytes"] / tr["table_bytes"],
        })
    lo, hi = sizes[0], sizes[-1]
    if hi > lo:
        a, b = res[lo], res[hi]
        growth = [
            ("files", hi - lo),
            ("table rows", b["traced"]["rows"] - a["traced"]["rows"]),
            ("time growth exponent (log-log slope, import + write)",
             math.log(b["total_s"] / a["total_s"]) / math.log(hi / lo)),
            ("ru_maxrss [MB]", (b["maxrss_bytes"] - a["maxrss_bytes"]) / MB),
            ("tracemalloc peak [MB]",
             (b["traced"]["peak_bytes"] - a["traced"]["peak_bytes"]) / MB),
            ("held after import [MB]",
             (b["traced"]["held_bytes"] - a["traced"]["held_bytes"]) / MB),
            ("tables (deep) [MB]",
             (b["traced"]["table_bytes"] - a["traced"]["table_bytes"]) / MB),
            ("tracemalloc peak per added file [kB]",
             (b["traced"]["peak_bytes"] - a["traced"]["peak_bytes"]) / (hi - lo) / 1e3),
            ("held after import per added file [kB]",
             (b["traced"]["held_bytes"] - a["traced"]["held_bytes"]) / (hi - lo) / 1e3),
            ("tables per added file [kB]",
             (b["traced"]["table_bytes"] - a["traced"]["table_bytes"]) / (hi - lo) / 1e3),
            ("growth of the tracemalloc peak / growth of the tables",
             (b["traced"]["peak_bytes"] - a["traced"]["peak_bytes"])
             / (b["traced"]["table_bytes"] - a["traced"]["table_bytes"])),
        ]
        rows += [{"table": f"growth from {lo:,} to {hi:,} files", "quantity": q, "value": v}
                 for q, v in growth]
    if cli is not None:
        rows += [{"table": f"python -m dpdfit import --no-progress, {hi:,} files, once",
                  "quantity": q, "value": v} for q, v in [
                      ("wall time, interpreter start included [s]", cli["wall_s"]),
                      ("per 1000 files [s]", 1e3 * cli["wall_s"] / hi),
                      ("user CPU [s]", cli["user_s"]),
                      ("system CPU [s]", cli["system_s"]),
                      ("ru_maxrss [MB]", cli["maxrss_bytes"] / MB)]]
    wall = time.perf_counter() - started
    notes = [f"import + write: median of {args.repeats} fresh child processes per N, "
             f"{args.repeats_largest} at N = {hi:,}; ru_maxrss is the largest of the timed "
             "children and includes the interpreter and libraries; the tracemalloc figures "
             "come from one further child per N (tracing started after the imports)",
             f"trees cached under {args.cache} ("
             + ", ".join(f"N = {n:,}: {'reused' if trees[n]['cached'] else 'generated'}"
                         for n in sizes) + "); generation times are those of the run that "
             "wrote each tree",
             f"wall time of this benchmark run {wall:.0f} s"]
    write_record(args.json, "import_scale", rows, description=summary_line(__doc__),
                 notes=notes)
    print(f"(benchmark run {wall:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
