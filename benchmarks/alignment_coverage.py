#!/usr/bin/env python
"""Coverage of the alpha/delta alignment fit over simulated campaigns of gate points.

    python benchmarks/alignment_coverage.py [N] [--json PATH]

Each replicate draws the 10 gate points of the paper's design (A = 0.4..0.8,
both flags) from a known alpha = 3.42 kHz and delta = -0.018 with 1 %
gate-rate calibration error, 0.2 dB laser-power fluctuation and 0.004
fidelity errors around a simulated sweep, fits, and counts how often the
truth lies within 1 and 2 reported standard errors.
"""

import argparse
import pathlib
import sys

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))   # the checkout's dpdfit
from dpdfit.fits.alignment import align  # noqa: E402
from dpdfit.analyses.sweep import SweepConfig, run_sweep  # noqa: E402
from dpdfit.simulation.aom_truth import truth_poly_tf  # noqa: E402
from dpdfit.simulation.gate_points import ALPHA, DELTA, SDB, simulated_gate  # noqa: E402
from record import add_json_option, summary_line, write_record  # noqa: E402


def main(n=2000, json_path=None):
    sweep = run_sweep(truth_poly_tf(), SweepConfig(amplitudes=np.linspace(0.3, 0.9, 25)))
    rng = np.random.default_rng(11)
    z = np.empty((n, 2))
    for i in range(n):
        fit = align(simulated_gate(sweep, rng), sweep, SDB)
        z[i] = [(fit.alpha_khz - ALPHA) / fit.alpha_khz_err, (fit.delta - DELTA) / fit.delta_err]
    rows = []
    for j, name in enumerate(("alpha", "delta")):
        c1, c2 = 100 * np.mean(np.abs(z[:, j]) <= 1), 100 * np.mean(np.abs(z[:, j]) <= 2)
        print(f"{name:5s}: within 1 sigma {c1:.1f} %, "
              f"within 2 sigma {c2:.1f} %  (N = {n}; "
              f"targets >= 60 % and >= 93 %; Gaussian 68.3 / 95.4)")
        rows.append({"parameter": name, "N": n, "within 1 sigma [%]": c1,
                     "target 1 sigma [%]": ">= 60", "within 2 sigma [%]": c2,
                     "target 2 sigma [%]": ">= 93", "Gaussian 1 / 2 sigma [%]": "68.3 / 95.4"})
    write_record(json_path, "alignment_coverage", rows, description=summary_line(__doc__))


if __name__ == "__main__":
    ap = add_json_option(argparse.ArgumentParser(description=summary_line(__doc__)))
    ap.add_argument("n", nargs="?", type=int, default=2000, metavar="N",
                    help="simulated campaigns (default 2000)")
    a = ap.parse_args()
    main(a.n, a.json)
