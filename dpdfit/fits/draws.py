"""Arrays of posterior draws: read-only copies, quantile summaries, the drift shift of y(1).

Shared by the amplitude posterior (:mod:`dpdfit.fits.posterior`), the drift
model (:mod:`dpdfit.fits.drift`) and the propagation of both into the fidelity
estimate (:mod:`dpdfit.analyses.propagation`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["QUANTILES", "read_only", "quantile_summary", "shift_y1"]

#: Quantiles reported for every sampled quantity: median, 68 % and 95 % intervals.
QUANTILES = {"median": 0.5, "q16": 0.16, "q84": 0.84, "q2.5": 0.025, "q97.5": 0.975}


def read_only(a) -> np.ndarray:
    """A float copy of ``a`` that cannot be written to (results are immutable)."""
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


def quantile_summary(x, axis=0) -> dict:
    """``{"median", "q16", "q84", "q2.5", "q97.5"}`` of the draws ``x`` along ``axis``."""
    x = np.asarray(x, dtype=float)
    q = np.quantile(x, list(QUANTILES.values()), axis=axis)
    return dict(zip(QUANTILES, q))


def shift_y1(a, delta):
    """Move ``y(1)`` of each row of ``a`` by ``delta``, scaling the nonlinear part.

    ``a_1 = 1`` is kept and ``a_k -> a_k (y1 - 1 + delta) / (y1 - 1)`` for
    ``k >= 2``: the unit slope at the origin and the *shape* of the
    compression are kept (the drift model of :mod:`dpdfit.fits.drift`).
    Returns ``(a, y1)`` with the shifted rows and their new ``y(1)``.
    """
    a = np.array(a, dtype=float, copy=True)
    y1 = a.sum(axis=1)
    nl = y1 - 1.0
    safe = np.where(np.abs(nl) > 1e-12, nl, 1e-12)
    a[:, 1:] *= ((nl + delta) / safe)[:, None]
    return a, a.sum(axis=1)
