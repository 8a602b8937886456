"""Gate points of the paper's design drawn from a known alpha and delta.

The 10 points (A = 0.4..0.8, both DPD flags) around a sweep, with 1 % gate-rate
calibration error, ``SDB`` dB laser-power fluctuation and 0.004 fidelity errors,
drawn from the alignment's own curves (:func:`dpdfit.fits.alignment.curves`): the
simulated campaigns of ``benchmarks/alignment_coverage.py`` and of the alignment and
adequacy tests.
"""

import pandas as pd

from dpdfit.fits.alignment import K_DB, curves

__all__ = ["ALPHA", "DELTA", "SDB", "AMPS", "simulated_gate"]

#: the true alignment (kHz per unit rate, fidelity offset) and laser-power fluctuation (dB)
ALPHA, DELTA, SDB = 3.42, -0.018, 0.2
#: the design's drive amplitudes, each recorded with and without DPD
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
