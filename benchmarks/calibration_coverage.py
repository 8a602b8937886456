#!/usr/bin/env python
"""Coverage of the reported 1-sigma errors of A_corr and phi(1), and inverse accuracy.

Simulates N calibrations (fixed seed) from the physical AOM model with the
realistic detector noise of dpdfit.simulation.aom_truth, fits each, and prints the
fraction of runs whose 1-sigma interval covers the truth (target 68.3 %),
the bias in units of the mean error bar, and the ratio of the scatter of the
estimates to the mean reported error.

    python benchmarks/calibration_coverage.py [N] [--json PATH]
"""

import argparse
import time

import numpy as np

from dpdfit.simulation.aom_truth import (BraggAOM, HeterodyneNoise, PhotodiodeNoise,
                              simulate_amplitude_run, simulate_phase_run)
from dpdfit.fits.calibration import fit_amplitude, fit_phase
from dpdfit.models.transfer import TransferFunction
from record import add_json_option, summary_line, write_record

ROWS = []


def summary(name, est, se, truth):
    n = est.size
    cover = np.mean(np.abs(est - truth) <= se)
    print(f"{name:38s} N={n}  coverage {100 * cover:5.1f} % (binomial sd {100 * np.sqrt(0.683 * 0.317 / n):.1f} %)"
          f"  bias/se {np.mean(est - truth) / se.mean():+.3f}  sd/se {est.std(ddof=1) / se.mean():.3f}"
          f"  mean se {se.mean():.2e}")
    ROWS.append({"table": "coverage of the reported 1-sigma error", "quantity": name, "N": n,
                 "coverage [%]": 100 * cover, "target [%]": 68.3,
                 "binomial sd [%]": 100 * np.sqrt(0.683 * 0.317 / n),
                 "bias / se": np.mean(est - truth) / se.mean(),
                 "sd / se": est.std(ddof=1) / se.mean(), "mean se": se.mean()})


def main(n=1000, json_path=None):
    aom = BraggAOM()
    A = np.linspace(0, 1, 201)
    t0 = time.perf_counter()
    for label, noise, with_err, seed in [
            ("A_corr, power_err given", PhotodiodeNoise(), True, 2026),
            ("A_corr, sigma from residuals", PhotodiodeNoise(sigma_0=1e-3, rel=0.0), False, 77)]:
        rng = np.random.default_rng(seed)
        est, se = np.empty(n), np.empty(n)
        for i in range(n):
            d = simulate_amplitude_run(aom, A, rng, noise)
            r = fit_amplitude(d.A, d.power, d.power_err if with_err else None)
            est[i], se[i] = r.A_corr, r.A_corr_stderr
        summary(label, est, se, aom.true_A_corr)
    rng = np.random.default_rng(11)
    est, se = np.empty(n), np.empty(n)
    worst = 0.0
    for i in range(n):
        p = simulate_phase_run(aom, A, rng, HeterodyneNoise())
        r = fit_phase(p.A, p.phase_rad, p.phase_err)
        est[i], se[i] = r.phi_at_1, r.phi_at_1_stderr
    summary("phi(1), phase_err given, 0.1<=A<=1", est, se, aom.true_phi_1)
    # inverse accuracy on a few fitted calibrations
    rng = np.random.default_rng(5)
    for i in range(20):
        d = simulate_amplitude_run(aom, A, rng)
        r = fit_amplitude(d.A, d.power, d.power_err)
        tf = TransferFunction(r.powers, r.coefficients)
        t = np.linspace(0, tf.A_corr, 100001)
        worst = max(worst, float(np.max(np.abs(tf.f_am(tf.inverse_am(t)) - t))))
    print(f"inverse: max |f_AM(f_AM^-1(y)) - y| on [0, A_corr] over 20 fits x 1e5 points: {worst:.2e}")
    total = time.perf_counter() - t0
    print(f"total time {total:.1f} s")
    ROWS.append({"table": "inverse accuracy and time",
                 "quantity": "max |f_AM(f_AM^-1(y)) - y| on [0, A_corr], 20 fits x 1e5 points",
                 "value": worst})
    ROWS.append({"table": "inverse accuracy and time", "quantity": "total time [s]",
                 "value": total})
    write_record(json_path, "calibration_coverage", ROWS, description=summary_line(__doc__))


if __name__ == "__main__":
    ap = add_json_option(argparse.ArgumentParser(description=summary_line(__doc__)))
    ap.add_argument("n", nargs="?", type=int, default=1000, metavar="N",
                    help="simulated calibrations per case (default 1000)")
    a = ap.parse_args()
    main(a.n, a.json)
