"""Speed and memory of `dpdfit import` on 200 ARTIQ results files.

    python benchmarks/import_speed.py [--files 200] [--shots 400] [--repeats 5] [--json PATH]

Writes one amplitude calibration and FILES-1 parity scans (16 phases, per-shot
outcome arrays of SHOTS shots: the heaviest shape a lab records) as ARTIQ/ndscan
results files into a temporary folder, then imports them REPEATS times and
prints the median wall time of :func:`import_campaign` plus writing the folder
(the whole of `dpdfit import` but the interpreter's start), its ratio to the
5 s target, and the peak memory (Python heap by tracemalloc in a separate run,
and the process's maximum resident size).
"""

from __future__ import annotations

import argparse
import resource
import statistics
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

from dpdfit.recordings.campaign_import import import_campaign
from dpdfit.simulation.artiq_results_file import (axis, channel, ndscan_datasets,
                                                  write_results_file)
from record import add_json_option, summary_line, write_record

TARGET_S = 5.0
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
n_even = { channel = "bright_ions", count = [0, 2] }
shots = { channel = "bright_ions", count = "all" }
'''


def write_lab(folder: Path, n_files: int, shots: int) -> None:
    rng = np.random.default_rng(1)
    a = np.linspace(0, 1, 201)
    write_results_file(folder, 1, "AmplitudeCalibration", 1.76e9, ndscan_datasets(
        1, "lab.AmplitudeCalibration", [axis("amplitude", a)], {"pd_power": channel(a ** 2)}))
    phases = np.arange(16) / 16
    for k in range(n_files - 1):
        rid = k + 2
        outcomes = rng.integers(0, 3, size=(16, shots))
        write_results_file(folder, rid, "ParityScan", 1.76e9 + 60 * rid, ndscan_datasets(
            rid, "lab.ParityScan", [axis("phase", phases, "turn")],
            {"bright_ions": channel(outcomes)}),
            arguments={"amplitude": round(0.1 + 0.1 * (k % 8), 1), "dpd": k % 2})


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--files", type=int, default=200)
    p.add_argument("--shots", type=int, default=400)
    p.add_argument("--repeats", type=int, default=5)
    add_json_option(p)
    args = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        lab = Path(tmp) / "lab"
        write_lab(lab, args.files, args.shots)
        (lab / "map.toml").write_text(MAPPING)
        size = sum(f.stat().st_size for f in lab.rglob("*.h5"))
        times = []
        for i in range(args.repeats):
            t = time.perf_counter()
            import_campaign(lab / "map.toml").write(Path(tmp) / f"campaign{i}")
            times.append(time.perf_counter() - t)
        tracemalloc.start()
        import_campaign(lab / "map.toml")
        heap = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    med = statistics.median(times)
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{args.files} results files ({size / 1e6:.1f} MB, {args.shots} shots per point)")
    print(f"import + write: median {med:.2f} s over {args.repeats} runs "
          f"(min {min(times):.2f}, max {max(times):.2f}); {1e3 * med / args.files:.1f} ms "
          f"per file; ratio to the {TARGET_S:g} s target {med / TARGET_S:.2f}")
    print(f"peak memory: Python heap {heap / 1e6:.1f} MB (tracemalloc), process maximum "
          f"resident {rss:.0f} MB")
    rows = [
        {"quantity": "results files", "value": args.files},
        {"quantity": "size of the files [MB]", "value": size / 1e6},
        {"quantity": "shots per point", "value": args.shots},
        {"quantity": f"import + write, median of {args.repeats} runs [s]", "value": med,
         "target": f"<= {TARGET_S:g}"},
        {"quantity": "import + write, min [s]", "value": min(times)},
        {"quantity": "import + write, max [s]", "value": max(times)},
        {"quantity": "per file [ms]", "value": 1e3 * med / args.files},
        {"quantity": "ratio of the median to the target", "value": med / TARGET_S,
         "target": "<= 1"},
        {"quantity": "peak Python heap (tracemalloc, separate run) [MB]", "value": heap / 1e6},
        {"quantity": "process maximum resident size [MB]", "value": rss},
    ]
    write_record(args.json, "import_speed", rows, description=summary_line(__doc__))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
