#!/usr/bin/env python
"""Wall time and peak memory of `dpdfit sweep` on the default grid (AM+PM, both flags).

    python benchmarks/sweep_speed.py [--json PATH]

Runs the installed command line in a child process 5 times (after calibrating
the bundled synthetic data once) and prints the median wall time and the
child's peak resident memory (ru_maxrss), including interpreter start-up and
imports; also the in-process time of run_sweep alone.
"""

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from record import add_json_option, summary_line, write_record

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "datasets" / "synthetic_aom"


def main(json_path=None):
    with tempfile.TemporaryDirectory() as tmp:
        cal = Path(tmp) / "cal.json"
        subprocess.run([sys.executable, "-m", "dpdfit.cli.main", "calibrate", "--amplitude",
                        str(DATA / "calibration_amplitude.csv"), "--phase",
                        str(DATA / "calibration_phase.csv"), "-o", str(cal), "--order-scan", "none"],
                       check=True, capture_output=True)
        walls = []
        for _ in range(5):
            t0 = time.perf_counter()
            subprocess.run([sys.executable, "-m", "dpdfit.cli.main", "sweep", str(cal), "-o",
                            str(Path(tmp) / "sweep.csv")], check=True, capture_output=True)
            walls.append(time.perf_counter() - t0)
        peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
        from dpdfit.fits.calibration import load_calibration
        from dpdfit.analyses.sweep import run_sweep
        from dpdfit.models.transfer import TransferFunction
        tf = TransferFunction.from_calibration(load_calibration(cal))
        inner = []
        for _ in range(7):
            t0 = time.perf_counter()
            run_sweep(tf)
            inner.append(time.perf_counter() - t0)
    print(f"dpdfit sweep (default grid: 100 A x 2 flags, AM+PM): median wall {np.median(walls):.2f} s "
          f"(target <= 3 s), peak RSS {peak_mb:.0f} MB (target < 1024 MB)")
    print(f"run_sweep alone: median {np.median(inner) * 1e3:.0f} ms")
    rows = [
        {"quantity": "dpdfit sweep, default grid (100 A x 2 flags, AM+PM): median wall of 5 "
                     "child runs, incl. start-up [s]", "value": float(np.median(walls)),
         "target": "<= 3"},
        {"quantity": "peak resident memory of the child processes [MB]", "value": peak_mb,
         "target": "< 1024"},
        {"quantity": "run_sweep alone, in-process: median of 7 [ms]",
         "value": float(np.median(inner)) * 1e3},
    ]
    write_record(json_path, "sweep_speed", rows, description=summary_line(__doc__))


if __name__ == "__main__":
    ap = add_json_option(argparse.ArgumentParser(description=summary_line(__doc__)))
    main(ap.parse_args().json)
