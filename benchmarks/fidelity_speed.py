#!/usr/bin/env python
"""Closed-form S5 fidelity estimate vs adaptive quadrature; scaling with the number of tones.

    python benchmarks/fidelity_speed.py [--json PATH]

Baselines integrate the geometric phase Phi(T_g) = -int F dG by adaptive
quadrature with the (trivial) analytic F(x) in the integrand:
(a) scipy.integrate.quad per spectrum, (b) scipy.integrate.quad_vec over the
whole batch at once.  Both are timed on the full batch of 10^4 spectra
(medians of repeated closed-form runs; the quadrature runs once, it is slow).
"""

import argparse
import time

import numpy as np
from scipy.integrate import quad, quad_vec

from dpdfit.models.fidelity import (amplitudes_from_powers, bell_fidelity, calibrate_g, estimate,
                             gate_phase_space)
from record import add_json_option, summary_line, write_record

N = 10_000
H = np.array([0, 1, 2, 3])


def spectra(rng, n):
    P = np.empty((n, 4))
    P[:, 1] = 0.0
    P[:, 2] = rng.normal(0, 0.3, n)
    P[:, 0] = rng.uniform(-60, -25, n)
    P[:, 3] = rng.uniform(-50, -20, n)
    return P


def quad_phi(r, g):
    k = np.sqrt(2) * g
    nz = H != 0

    def F(x):
        return -k * (np.sum(r[nz] * np.sin(H[nz] * x) / H[nz]) + r[~nz].sum() * x)

    def dG(x):
        return k * np.sum(r * np.sin(H * x))

    return quad(lambda x: -F(x) * dG(x), 0, 2 * np.pi, epsabs=1e-13, epsrel=1e-12, limit=200)[0]


def main(json_path=None):
    rng = np.random.default_rng(1)
    P = spectra(rng, N)
    times = []
    for _ in range(7):
        t0 = time.perf_counter()
        est = estimate(P, tuple(H), nbar=0.1)
        times.append(time.perf_counter() - t0)
    t_closed = float(np.median(times))
    r = amplitudes_from_powers(P, tuple(H))
    g = calibrate_g(H, r)

    t0 = time.perf_counter()
    phi_quad = np.array([quad_phi(r[i], g[i]) for i in range(N)])
    t_quad = time.perf_counter() - t0

    k = np.sqrt(2) * g
    nz = H != 0

    def integrand(x):
        F = -k * (r[:, nz] @ (np.sin(H[nz] * x) / H[nz]) + r[:, ~nz].sum(axis=1) * x)
        dG = k * (r @ np.sin(H * x))
        return -F * dG

    t0 = time.perf_counter()
    phi_qv, _ = quad_vec(integrand, 0, 2 * np.pi, epsabs=1e-13, epsrel=1e-12, norm="max")
    t_qv = time.perf_counter() - t0

    F_q = bell_fidelity(est.F, est.G, phi_quad, 0.1)
    print(f"batch of {N} spectra (4 tones):")
    print(f"  closed form (F_est incl. amplitudes, calibration, F, G, Phi): median "
          f"{t_closed * 1e3:.2f} ms = {t_closed / N * 1e6:.3f} us/spectrum")
    print(f"  adaptive quad per spectrum:  {t_quad:.2f} s   ratio {t_quad / t_closed:,.0f}x")
    print(f"  adaptive quad_vec on batch:  {t_qv:.3f} s   ratio {t_qv / t_closed:,.0f}x")
    print(f"  max |Phi_closed - Phi_quad|     = {np.max(np.abs(est.Phi - phi_quad)):.2e}")
    print(f"  max |Phi_closed - Phi_quad_vec| = {np.max(np.abs(est.Phi - phi_qv)):.2e}")
    print(f"  max |F_est closed - F_est(quad Phi)| = {np.max(np.abs(est.F_est - F_q)):.2e}")
    batch = f"batch of {N} spectra (4 tones)"
    rows = [
        {"table": batch, "method": "closed form (F_est incl. amplitudes, calibration, F, G, Phi), "
         "median of 7", "time [s]": t_closed, "per spectrum [us]": t_closed / N * 1e6,
         "ratio to closed form": 1.0},
        {"table": batch, "method": "adaptive quad per spectrum (one run)", "time [s]": t_quad,
         "per spectrum [us]": t_quad / N * 1e6, "ratio to closed form": t_quad / t_closed},
        {"table": batch, "method": "adaptive quad_vec on the batch (one run)", "time [s]": t_qv,
         "per spectrum [us]": t_qv / N * 1e6, "ratio to closed form": t_qv / t_closed},
        {"table": "agreement", "quantity": "max |Phi_closed - Phi_quad|",
         "value": np.max(np.abs(est.Phi - phi_quad))},
        {"table": "agreement", "quantity": "max |Phi_closed - Phi_quad_vec|",
         "value": np.max(np.abs(est.Phi - phi_qv))},
        {"table": "agreement", "quantity": "max |F_est closed - F_est(quad Phi)|",
         "value": np.max(np.abs(est.F_est - F_q))},
    ]

    print("time per spectrum vs number of tones (batch of 2000, closed form at T_g):")
    for T in (4, 16, 64):
        n = np.arange(T)
        rr = rng.normal(size=(2000, T))
        gg = calibrate_g(n, rr, (1, 2))
        ts = []
        for _ in range(7):
            t0 = time.perf_counter()
            gate_phase_space(n, rr, 0.0, gg)
            ts.append(time.perf_counter() - t0)
        print(f"  {T:3d} tones: {np.median(ts) / 2000 * 1e6:8.3f} us/spectrum")
        rows.append({"table": "time per spectrum vs number of tones (batch of 2000, "
                              "closed form at T_g, median of 7)",
                     "tones": T, "per spectrum [us]": np.median(ts) / 2000 * 1e6})
    print("  (the geometric phase is a T x T quadratic form per spectrum: O(T^2))")
    write_record(json_path, "fidelity_speed", rows, description=summary_line(__doc__),
                 notes=["The geometric phase is a T x T quadratic form per spectrum: O(T^2)."])


if __name__ == "__main__":
    ap = add_json_option(argparse.ArgumentParser(description=summary_line(__doc__)))
    main(ap.parse_args().json)
