"""Speed of the calibration posterior and of the drift propagation.

1. Effective independent samples per second (ESS/s) of
   :func:`dpdfit.fits.posterior.sample_amplitude_posterior` against lmfit's
   ``Minimizer.emcee`` on the same posterior (one simulated 201-point run of
   the Bragg AOM with the default photodiode noise, K = 8, ``power_err``
   given, flat priors, b_1 > 0), same walkers and steps, same start (draws of
   the Laplace approximation), same machine, same run.  ESS = walkers x kept
   steps / max tau, tau from ``emcee.autocorr.integrated_time`` (c=5, tol=0)
   over all parameters and A_corr; the wall time is the sampling time only.
   dpdfit is run with its default moves (Laplace-t independence + stretch) and
   with plain stretch moves (the same algorithm as lmfit; shows how much of
   the gain is vectorisation and how much is the proposal).
2. Wall time of ``propagate`` for 10^4 draws at one A, both DPD flags
   (posterior already sampled), and of the whole pipeline from a runs table.

Run: ``python benchmarks/posterior_speed.py [--json PATH]``  (targets: ESS/s ratio >= 10,
propagation <= 10 s).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pandas as pd

from dpdfit.simulation.aom_truth import BraggAOM, PhotodiodeNoise, simulate_amplitude_run
from dpdfit.fits.calibration import fit_amplitude
from dpdfit.analyses.propagation import propagate
from dpdfit.fits.posterior import sample_amplitude_posterior
from record import add_json_option, summary_line, write_record


def ess(chain):
    from emcee.autocorr import integrated_time
    b = chain[..., :8]
    Ac = b.sum(axis=-1) / b[..., 0]
    full = np.concatenate([chain, Ac[..., None]], axis=-1)
    tau = float(np.max(integrated_time(full, c=5, tol=0, quiet=True)))
    return chain.shape[0] * chain.shape[1] / tau, tau


def run_lmfit(A, P, S, fit, nwalkers, steps, burn, seed):
    import lmfit
    params = lmfit.Parameters()
    for k, v in enumerate(fit.raw_coefficients):
        params.add(f"b{k + 1}", value=float(v), min=0.0 if k == 0 else -np.inf)
    V = A[:, None] ** np.arange(1, 9)

    def resid(p):
        b = np.array([p[f"b{k}"].value for k in range(1, 9)])
        return (P - (V @ b) ** 2) / S

    rng = np.random.default_rng(seed)
    L = np.linalg.cholesky(np.asarray(fit.raw_covariance))
    pos = np.asarray(fit.raw_coefficients) + rng.standard_normal((nwalkers, 8)) @ L.T
    pos[:, 0] = np.abs(pos[:, 0])
    mini = lmfit.Minimizer(resid, params, nan_policy="omit")
    t0 = time.perf_counter()
    res = mini.emcee(steps=steps, nwalkers=nwalkers, burn=burn, pos=pos, is_weighted=True,
                     progress=False, seed=seed)
    wall = time.perf_counter() - t0
    n, t = ess(np.asarray(res.chain))
    return n, t, wall


def main(json_path=None):
    rng = np.random.default_rng(2026)
    A = np.linspace(0, 1, 201)
    df = simulate_amplitude_run(BraggAOM(), A, rng, PhotodiodeNoise())
    P, S = df["power"].to_numpy(), df["power_err"].to_numpy()
    fit = fit_amplitude(A, P, S, 8)
    nw, steps, burn = 32, 4000, 800

    rows = []
    n_l, tau_l, wall_l = run_lmfit(A, P, S, fit, nw, steps, burn, 1)
    rows.append(("lmfit Minimizer.emcee (stretch)", tau_l, n_l, wall_l))
    for moves in ("laplace", "stretch"):
        r = sample_amplitude_posterior(A, P, S, 8, n_walkers=nw, n_steps=steps, burn=burn / steps,
                                       seed=1, fit=fit, moves=moves, force=True)
        rows.append((f"dpdfit ({moves}, vectorised)", r.tau_max, r.n_independent, r.wall_time))
    print(f"posterior: {nw} walkers x {steps} steps ({burn} burn-in), K = 8, 201 points")
    print(f"{'sampler':38s} {'tau':>8s} {'ESS':>9s} {'wall s':>8s} {'ESS/s':>10s}")
    for name, tau, n, wall in rows:
        print(f"{name:38s} {tau:8.2f} {n:9.0f} {wall:8.2f} {n / wall:10.0f}")
    base = rows[0][2] / rows[0][3]
    for name, tau, n, wall in rows[1:]:
        print(f"ESS/s ratio {name} / lmfit: {n / wall / base:.0f}x  (target >= 10)")
    samplers = f"posterior: {nw} walkers x {steps} steps ({burn} burn-in), K = 8, 201 points"
    record = [{"table": samplers, "sampler": name, "tau": tau, "ESS": n, "wall [s]": wall,
               "ESS/s": n / wall, "ESS/s ratio to lmfit": n / wall / base,
               "target ratio": None if i == 0 else ">= 10"}
              for i, (name, tau, n, wall) in enumerate(rows)]
    prop = "propagation"

    # --- propagation
    post = sample_amplitude_posterior(A, P, S, 8, n_walkers=32, n_steps=400, seed=2, fit=fit)
    propagate(post, 0.5, draws=100, seed=0)            # warm-up (imports)
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        res = propagate(post, 0.5, draws=10_000, seed=0)
        times.append(time.perf_counter() - t0)
    print(f"propagate 10^4 draws at A = 0.5, both flags: median {np.median(times):.3f} s "
          f"(best {min(times):.3f} s; target <= 10 s)")
    d = res.to_dict()
    print(f"  F_est dpd {d['dpd']['F_est_median']:.6f}, no_dpd {d['no_dpd']['F_est_median']:.6f}")
    record += [
        {"table": prop, "quantity": "propagate 10^4 draws at A = 0.5, both flags: median of 3 [s]",
         "value": float(np.median(times)), "target": "<= 10"},
        {"table": prop, "quantity": "same, best of 3 [s]", "value": min(times)},
        {"table": prop, "quantity": "F_est median, dpd", "value": d["dpd"]["F_est_median"]},
        {"table": prop, "quantity": "F_est median, no_dpd", "value": d["no_dpd"]["F_est_median"]},
    ]

    # whole pipeline from a runs table: 34 runs, fits + posterior + drift + 10^4 draws
    frames = []
    t_start = pd.Timestamp("2026-01-01T09:00Z")
    for k in range(34):
        aom = BraggAOM(A_corr=0.5655 + 0.009 * rng.standard_normal())
        r = simulate_amplitude_run(aom, A, rng)
        r.insert(0, "timestamp", (t_start + pd.Timedelta(days=3.3 * k)).isoformat())
        r.insert(0, "run", f"R{k + 1:03d}")
        frames.append(r)
    runs = pd.concat(frames, ignore_index=True)
    t0 = time.perf_counter()
    res = propagate(runs, 0.5, stale_days=3, draws=10_000, seed=0, recalibration_loss=1e-4)
    t_full = time.perf_counter() - t0
    print(f"full pipeline (34 runs fitted, posterior, drift model, 10^4 draws, recalibration): "
          f"{t_full:.2f} s")
    record.append({"table": prop, "quantity": "full pipeline from a runs table (34 runs fitted, "
                   "posterior, drift model, 10^4 draws, recalibration), one run [s]",
                   "value": t_full})
    write_record(json_path, "posterior_speed", record, description=summary_line(__doc__))


if __name__ == "__main__":
    ap = add_json_option(argparse.ArgumentParser(description=summary_line(__doc__)))
    main(ap.parse_args().json)
