"""Gate points of the paper's design drawn from a known alpha and delta.

The 10 points (A = 0.4..0.8, both DPD flags) around a sweep, with 1 % gate-rate
calibration error, ``SDB`` dB laser-power fluctuation and 0.004 fidelity errors:
the simulated campaigns of ``alignment_coverage.py``, and of the alignment and
adequacy tests (``from benchmarks.gate_points import simulated_gate``).
"""

import pandas as pd

from dpdfit.fits.alignment import K_DB, curves

ALPHA, DELTA, SDB = 3.42, -0.018, 0.2
AMPS = (0.4, 0.5, 0.6, 0.7, 0.8)


def simulated_gate(sweep, rng, alpha=ALPHA, delta=DELTA, sdb=SDB):
    """One simulated table of gate points (``A, dpd, xi0_khz, xi0_err_khz, F, F_err``)."""
    cv = curves(sweep)
    rows = []
    for d in (0, 1):
        for A in AMPS:
            r = float(cv[d]["r_rel"](A))
            s = 0.01 * alpha * r
            xi = alpha * r * (1 + K_DB * sdb * rng.standard_normal()) + s * rng.standard_normal()
            e = 0.004
            F = float(cv[d]["F_est"](A)) + delta + e * rng.standard_normal()
            rows.append({"A": A, "dpd": d, "xi0_khz": xi, "xi0_err_khz": s, "F": F, "F_err": e})
    return pd.DataFrame(rows)
