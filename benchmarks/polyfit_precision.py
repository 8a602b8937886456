"""Precision and speed of dpdfit.fits.polyfit against plain double least squares.

Run:  python benchmarks/polyfit_precision.py [repeats] [--json PATH]

For two ill-conditioned monomial designs (degree 10 with constant on
x in [-9, -3], raw condition number ~1e15; powers 1..8 on x in [0, 1]), with
and without sigma, prints the number of matching significant digits
(min over coefficients of -log10(relative error)) of the coefficients and
their standard errors against a 50-digit mpmath solution of the very same
problem (the double x, y, sigma converted exactly), for

* dpdfit.fits.polyfit (double-double iterative refinement),
* np.linalg.lstsq on the raw (weighted) Vandermonde matrix, with standard
  errors from its pseudo-inverse, with numpy's default singular-value cut-off
  (which drops the smallest singular value at cond 1e15) and without one,
* np.polynomial.polynomial.polyfit (column-scaled lstsq; no standard errors),

followed by the median wall time per fit of polyfit and lstsq.
"""

from __future__ import annotations

import argparse
import math
import pathlib
import sys
import time

import mpmath
import numpy as np

try:
    from dpdfit.fits.polyfit import polyfit
except ImportError:                      # run from a source checkout
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))
    from dpdfit.fits.polyfit import polyfit

# problems and the 50-digit reference: the very ones tests/fits/test_polyfit.py checks
from dpdfit.simulation.polyfit_problems import hard_case, no_constant_case  # noqa: E402
from dpdfit.simulation.polyfit_problems import mp_reference as _mp_reference  # noqa: E402
from record import add_json_option, summary_line, write_record  # noqa: E402

CASES = [
    ("degree 10 with constant, x in [-9,-3], 60 points", hard_case),
    ("powers 1..8 (no constant), x in [0,1], 60 points", no_constant_case),
]


def mp_reference(x, y, powers, sigma):
    """(coefficients, stderr) of the 50-digit solution (dpdfit.simulation.polyfit_problems)."""
    ref = _mp_reference(x, y, powers, sigma)
    return ref["coefficients"], ref["stderr"]


def weighted_vandermonde(x, y, powers, sigma):
    w = np.ones_like(x) if sigma is None else 1.0 / sigma
    return x[:, None] ** np.array(powers, dtype=float) * w[:, None], y * w


def lstsq_fit(x, y, powers, sigma, truncate=True):
    """np.linalg.lstsq on the raw Vandermonde; stderr from the pseudo-inverse.

    ``truncate=True`` uses numpy's default cut-offs (lstsq: singular values
    below ``n * eps * s_max`` are dropped, pinv: below ``1e-15 * s_max``);
    ``truncate=False`` keeps every singular value (``rcond=-1`` / ``rtol=0``).
    """
    A, b = weighted_vandermonde(x, y, powers, sigma)
    if truncate:
        coef = np.linalg.lstsq(A, b, rcond=None)[0]
        pinv = np.linalg.pinv(A)
    else:
        coef = np.linalg.lstsq(A, b, rcond=-1)[0]
        pinv = np.linalg.pinv(A, rtol=0)
    cov = pinv @ pinv.T
    if sigma is None:
        cov = cov * np.sum((b - A @ coef) ** 2) / (len(x) - len(powers))
    return coef, np.sqrt(np.abs(np.diag(cov)))


def numpy_polyfit(x, y, powers, sigma):
    w = None if sigma is None else 1.0 / sigma
    full = np.polynomial.polynomial.polyfit(x, y, list(powers), w=w)
    return full[list(powers)]


def digits(values, reference):
    """min_j -log10(|v_j - ref_j| / |ref_j|)  (17 when exact)."""
    with mpmath.workdps(50):
        worst = max(float(abs((mpmath.mpf(float(v)) - r) / r))
                    for v, r in zip(values, reference))
    return 17.0 if worst == 0 else -math.log10(worst)


def median_time(fn, repeats):
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


# --------------------------------------------------------------------------
def main(repeats=200, json_path=None):
    rows = []
    print(__doc__.split("\n\n")[0])
    print(f"numpy {np.__version__}, mpmath {mpmath.__version__}; "
          f"digits = min over coefficients of -log10(relative error vs 50-digit mpmath)\n")
    for title, make in CASES:
        print(f"== {title}")
        for with_sigma in (False, True):
            x, y, powers, sigma = make(with_sigma)
            ref_c, ref_s = mp_reference(x, y, powers, sigma)
            res = polyfit(x, y, powers, sigma=sigma)
            lc, ls = lstsq_fit(x, y, powers, sigma)
            uc, us = lstsq_fit(x, y, powers, sigma, truncate=False)
            nc = numpy_polyfit(x, y, powers, sigma)
            label = "sigma given" if with_sigma else "sigma from residuals"
            rank = np.linalg.matrix_rank(weighted_vandermonde(x, y, powers, sigma)[0])
            digits_table = "significant digits against the 50-digit mpmath solution"
            rows.append({"table": "conditioning", "problem": title, "sigma": label,
                         "cond (weighted Vandermonde)": res.condition_number,
                         "cond after power-of-two column scaling": res.condition_number_scaled,
                         "polyfit refinement iterations": res.refinement_iterations,
                         "converged": bool(res.converged)})
            for method, c, s_ in (
                    ("dpdfit.fits.polyfit", digits(res.coefficients, ref_c),
                     digits(res.stderr, ref_s)),
                    (f"np.linalg.lstsq, raw Vandermonde (default rcond: rank {rank} of "
                     f"{len(powers)})", digits(lc, ref_c), digits(ls, ref_s)),
                    ("np.linalg.lstsq, no singular-value cut-off", digits(uc, ref_c),
                     digits(us, ref_s)),
                    ("np.polynomial.polynomial.polyfit", digits(nc, ref_c), None)):
                rows.append({"table": digits_table, "problem": title, "sigma": label,
                             "method": method, "coefficient digits": c, "stderr digits": s_})
            print(f"  [{label}]  cond(weighted Vandermonde) = {res.condition_number:.3g}, "
                  f"after power-of-two column scaling {res.condition_number_scaled:.3g}")
            print(f"    {'method':<40}{'coef digits':>12}{'stderr digits':>15}")
            print(f"    {'dpdfit.fits.polyfit':<40}{digits(res.coefficients, ref_c):>12.1f}"
                  f"{digits(res.stderr, ref_s):>15.1f}"
                  f"   ({res.refinement_iterations} refinement iterations, "
                  f"{'converged' if res.converged else 'NOT converged'})")
            print(f"    {'np.linalg.lstsq, raw Vandermonde':<40}{digits(lc, ref_c):>12.1f}"
                  f"{digits(ls, ref_s):>15.1f}   (numpy default rcond: "
                  f"rank {rank}"
                  f" of {len(powers)})")
            print(f"    {'  same, no singular-value cut-off':<40}{digits(uc, ref_c):>12.1f}"
                  f"{digits(us, ref_s):>15.1f}")
            print(f"    {'np.polynomial.polynomial.polyfit':<40}{digits(nc, ref_c):>12.1f}"
                  f"{'n/a':>15}")
            if with_sigma:
                t_ours = median_time(lambda: polyfit(x, y, powers, sigma=sigma), repeats)
                A, b = weighted_vandermonde(x, y, powers, sigma)
                t_lstsq = median_time(lambda: np.linalg.lstsq(A, b, rcond=None), repeats)
                t_both = median_time(lambda: lstsq_fit(x, y, powers, sigma), repeats)
                print(f"    median time per fit over {repeats} runs: polyfit "
                      f"{t_ours * 1e3:.2f} ms (coefficients + covariance + statistics), "
                      f"lstsq {t_lstsq * 1e3:.3f} ms (coefficients only; "
                      f"{t_both * 1e3:.3f} ms with Vandermonde + pinv covariance); "
                      f"ratio {t_ours / t_lstsq:.0f}x / {t_ours / t_both:.0f}x")
                rows.append({"table": f"median time per fit over {repeats} runs (sigma given)",
                             "problem": title,
                             "polyfit, coefficients + covariance + statistics [ms]": t_ours * 1e3,
                             "lstsq, coefficients only [ms]": t_lstsq * 1e3,
                             "lstsq with Vandermonde + pinv covariance [ms]": t_both * 1e3,
                             "ratio polyfit / lstsq": t_ours / t_lstsq,
                             "ratio polyfit / (lstsq + pinv)": t_ours / t_both})
        print()
    write_record(json_path, "polyfit_precision", rows, description=summary_line(__doc__),
                 notes=[f"numpy {np.__version__}, mpmath {mpmath.__version__}; digits = min "
                        "over coefficients of -log10(relative error vs 50-digit mpmath), "
                        "17 when exact."])


if __name__ == "__main__":
    ap = add_json_option(argparse.ArgumentParser(description=summary_line(__doc__)))
    ap.add_argument("repeats", nargs="?", type=int, default=200,
                    help="timed fits per method (default 200)")
    a = ap.parse_args()
    main(a.repeats, a.json)
