"""The gate engine for the further recordings of a campaign: many scans of one setting.

A further recording (:attr:`CampaignConfig.further`, what the closed loop adds) may be
hundreds of scans of one setting: a proposal fills the lab time it is given, and a scan
is short.  Each scan carries its own laser-power jitter ``eps`` (dB), so each was one
engine run (about a second), and one proposal could take the simulator half an hour.

The scans of one setting differ only in ``eps``, and the outcome probabilities are a
smooth (analytic) function of the drive power.  :class:`FurtherEngine` therefore runs the
engine exactly for a setting with few scans (the outcome bit for bit as before), and for
a setting with more than :data:`INTERPOLATE_ABOVE` scans at :data:`CHEBYSHEV_NODES`
Chebyshev nodes of ``eps`` over ``+-`` :data:`JITTER_SPAN` jitter standard deviations,
interpolating each outcome probability in between (a draw outside the span runs the
engine).  The interpolation error is far below the engine's own integration tolerance
(``tests/simulation/test_further_engine.py`` compares it with exact runs), so the counts drawn
from it are the recording's law.  A time scan carries no per-scan jitter; its repeats
reuse the first run exactly.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from numpy.polynomial import chebyshev

__all__ = ["FurtherEngine", "jittered_scan_counts", "INTERPOLATE_ABOVE", "CHEBYSHEV_NODES",
           "JITTER_SPAN"]

#: a setting with more further scans than this is interpolated in the power jitter
INTERPOLATE_ABOVE = 24
#: Chebyshev nodes of the power jitter at which the engine runs
CHEBYSHEV_NODES = 12
#: half-width of the interpolated span, in jitter standard deviations
JITTER_SPAN = 6.0


class FurtherEngine:
    """Engine outcomes of the further scans of one campaign (module doc).

    Parameters
    ----------
    counts : dict
        ``{(A, dpd): number of further jittered scans}`` of the campaign.
    sigma_db : float
        The per-scan laser-power jitter (dB).
    run : callable
        ``run(A, dpd, eps_db, scan_times=None)`` -> :class:`SettingProbabilities`, the
        exact engine at a setting.
    """

    def __init__(self, counts: dict, sigma_db: float, run):
        self.counts = dict(counts)
        self.sigma = float(sigma_db)
        self.run = run
        self._fits: dict = {}
        self._exact: dict = {}

    def scan(self, A: float, d: int, eps_db: float):
        """The outcome of one scan at ``(A, d)`` with power jitter ``eps_db``."""
        key = (float(A), int(d))
        half = JITTER_SPAN * self.sigma
        if (self.counts.get(key, 0) <= INTERPOLATE_ABOVE or not half > 0
                or abs(eps_db) > half):
            return self.run(A, d, eps_db)
        if key not in self._fits:
            self._fits[key] = self._interpolant(A, d, half)
        base, cpop, cpar = self._fits[key]
        x = eps_db / half
        pop = chebyshev.chebval(x, cpop)
        par = chebyshev.chebval(x, cpar)
        nan = float("nan")
        # only the outcome probabilities are interpolated: the state and the fidelities
        # of a node would be another scan's, so they are left undefined
        return dataclasses.replace(
            base, pop=np.asarray(pop, dtype=float), parity_probs=np.asarray(par, dtype=float),
            rho_gate=np.full_like(base.rho_gate, nan), fidelity=nan, fidelity_max=nan,
            fidelity_gate=nan, params={**base.params, "power_error_db": nan},
            info={"interpolated_eps_db": float(eps_db)})

    def _interpolant(self, A, d, half):
        nodes = chebyshev.chebpts1(CHEBYSHEV_NODES)
        runs = [self.run(A, d, half * x) for x in nodes]
        pops = np.array([r.pop for r in runs])                         # (nodes, 3)
        pars = np.array([r.parity_probs for r in runs])                # (nodes, K, 3)
        cpop = chebyshev.chebfit(nodes, pops, CHEBYSHEV_NODES - 1)
        cpar = chebyshev.chebfit(nodes, pars.reshape(len(nodes), -1), CHEBYSHEV_NODES - 1)
        # coefficients (deg + 1, K, 3): chebval gives (K, 3) at a scalar x
        return runs[0], cpop, cpar.reshape(CHEBYSHEV_NODES, *pars.shape[1:])

    def time_scan(self, A: float, d: int, xi_cal: float, scan_times):
        """The outcome of a time scan (no per-scan jitter: a repeat reuses the first)."""
        t = np.asarray(scan_times, dtype=float)
        key = (float(A), int(d), float(xi_cal), t.tobytes())
        if key not in self._exact:
            self._exact[key] = self.run(A, d, 0.0, scan_times=t)
        return self._exact[key]


def jittered_scan_counts(further) -> dict:
    """``{(A, dpd): number of further scans}`` of the ``("scan", ...)`` items of a
    config's ``further``."""
    out: dict = {}
    for item in further:
        if item[0] == "scan":
            key = (float(item[1]), int(item[2]))
            out[key] = out.get(key, 0) + 1
    return out
