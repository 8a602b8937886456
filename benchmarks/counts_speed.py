#!/usr/bin/env python
"""Speed of the raw-count inference (dpdfit.fits.counts, Supplement S7).

    python benchmarks/counts_speed.py [--json PATH]

1. Parity fits per second on one core (BLAS threads pinned to 1): binomial
   MLE of a 16-phase x 625-shot scan with the finite-difference Hessian, the
   Fisher cross-check and the boundary policy -- i.e. the full
   ``fit_parity`` -- at contrast 0.96 (Hessian regime; target >= 1000/s),
   and at 0.995 (boundary regime: mostly profile-likelihood intervals).
   For scale, a generic baseline: ``scipy.optimize.minimize`` (L-BFGS-B in
   (A, phi0) with 0 <= A <= 1) plus the same finite-difference Hessian.
2. Wall time of the count analysis of the bundled campaign
   ``datasets/synthetic_campaign/`` (read_populations + read_parity +
   gate_fidelities; target <= 2 s).

Medians over repeated runs; no assertions (the tests do not time anything).
"""

import os

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from scipy.optimize import minimize  # noqa: E402
from scipy.special import xlogy  # noqa: E402

from dpdfit.fits.counts import HESSIAN_FD_STEP, fit_parity, gate_fidelities  # noqa: E402
from dpdfit.recordings.counts import read_parity, read_populations  # noqa: E402
from record import add_json_option, summary_line, write_record  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CAMPAIGN = ROOT / "datasets" / "synthetic_campaign"
PHI = np.arange(16) * 2 * np.pi / 16
N = 625


def scans(rng, A, count):
    out = []
    for _ in range(count):
        phi0 = rng.uniform(-np.pi, np.pi)
        out.append(rng.binomial(N, (1 + A * np.cos(2 * PHI + phi0)) / 2))
    return out


def rate(ks, repeats=5):
    """Median fits per second and the methods used."""
    methods = {}
    times = []
    for rep in range(repeats):
        t0 = time.perf_counter()
        for k in ks:
            r = fit_parity(PHI, k, N)
            if rep == 0:
                methods[r.method] = methods.get(r.method, 0) + 1
        times.append(time.perf_counter() - t0)
    return len(ks) / float(np.median(times)), methods


def baseline_fit(k):
    """Generic route: L-BFGS-B in (A, phi0) + the same 9-point FD Hessian."""
    c2 = 2 * PHI

    def nll(x):
        p = 0.5 * (1 + x[0] * np.cos(c2 + x[1]))
        return -float(np.sum(xlogy(k, p) + xlogy(N - k, 1 - p)))

    y = 2 * k / N - 1
    a, b = np.mean(y * np.cos(c2)) * 2, -np.mean(y * np.sin(c2)) * 2
    x0 = [min(np.hypot(a, b), 0.99), np.arctan2(b, a)]
    res = minimize(nll, x0, method="L-BFGS-B", bounds=[(0, 1), (None, None)])
    h = HESSIAN_FD_STEP
    f0 = nll(res.x)
    H = np.empty((2, 2))
    for i in range(2):
        e = np.zeros(2)
        e[i] = h
        H[i, i] = (nll(res.x + e) - 2 * f0 + nll(res.x - e)) / h ** 2
    e0, e1 = np.array([h, 0]), np.array([0, h])
    H[0, 1] = H[1, 0] = (nll(res.x + e0 + e1) - nll(res.x + e0 - e1) - nll(res.x - e0 + e1)
                         + nll(res.x - e0 - e1)) / (4 * h * h)
    return res.x, np.linalg.inv(H)


def main(json_path=None):
    rng = np.random.default_rng(2026)
    fits_table = "parity fits (16 phases x 625 shots, one core)"
    rows = []
    print("Parity fits (16 phases x 625 shots, one core):")
    for A in (0.96, 0.995):
        r, methods = rate(scans(rng, A, 1000))
        print(f"  contrast {A}: {r:,.0f} fits/s ({1e6 / r:.0f} us per fit); methods {methods}")
        rows.append({"table": fits_table, "fit": "fit_parity", "contrast": A,
                     "rate [fits/s]": r, "time per fit [us]": 1e6 / r,
                     "target [fits/s]": ">= 1000" if A == 0.96 else None,
                     "methods (of 1000)": ", ".join(f"{k}: {v}" for k, v in methods.items())})
    ks = scans(rng, 0.96, 200)
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        for k in ks:
            baseline_fit(k)
        times.append(time.perf_counter() - t0)
    rb = len(ks) / float(np.median(times))
    print(f"  baseline scipy L-BFGS-B + FD Hessian at 0.96: {rb:,.0f} fits/s")
    rows.append({"table": fits_table, "fit": "baseline: scipy L-BFGS-B + FD Hessian",
                 "contrast": 0.96, "rate [fits/s]": rb, "time per fit [us]": 1e6 / rb})

    print("Count analysis of the bundled campaign (read + pool + fit + combine):")
    times = []
    for _ in range(7):
        t0 = time.perf_counter()
        pop = read_populations(CAMPAIGN / "populations.csv")
        par = read_parity(CAMPAIGN / "parity.csv")
        g = gate_fidelities(pop, par)
        times.append(time.perf_counter() - t0)
    print(f"  {len(g)} settings, {len(par)} parity rows, {len(pop)} population rows: "
          f"median {np.median(times) * 1e3:.0f} ms (first run {times[0] * 1e3:.0f} ms)")
    cols = ["A", "dpd", "F_pop", "F_par", "F", "F_err", "parity_method", "parity_scan_p"]
    print(g[cols].to_string(index=False, float_format=lambda v: f"{v:.4f}"))
    rows.append({"table": "count analysis of the bundled campaign (read + pool + fit + combine)",
                 "settings": len(g), "parity rows": len(par), "population rows": len(pop),
                 "median of 7 [ms]": np.median(times) * 1e3, "first run [ms]": times[0] * 1e3,
                 "target [ms]": "<= 2000"})
    rows += [{"table": "gate fidelities of the bundled campaign", **rec}
             for rec in g[cols].to_dict(orient="records")]
    write_record(json_path, "counts_speed", rows, description=summary_line(__doc__),
                 notes=["BLAS threads pinned to 1; fit rates are medians of 5 passes over "
                        "1000 scans (baseline: 3 passes over 200)."])


if __name__ == "__main__":
    ap = add_json_option(argparse.ArgumentParser(description=summary_line(__doc__)))
    main(ap.parse_args().json)
