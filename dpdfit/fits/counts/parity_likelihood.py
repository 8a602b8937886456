"""The binomial likelihood of a parity fringe and its derivatives (Supplement S7.2).

``Pi(phi) = A cos(2 phi + phi0)``; at each phase the probability of an even
outcome is ``p_i = (1 + A cos(2 phi_i + phi0)) / 2`` and the negative
log-likelihood ``-lnL = -sum k_i ln p_i + (n_i - k_i) ln(1 - p_i)`` (S7.2,
without the constant binomial coefficients) is minimised under ``|A| <= 1``.

In ``(a, b) = (A cos phi0, -A sin phi0)`` the probabilities are linear in the
parameters, so ``-lnL`` is convex on the disk ``a^2 + b^2 <= 1``; on its
boundary circle ``A = 1`` and at fixed ``A`` it is a function of ``phi0``
alone.  This module evaluates ``-lnL`` and its derivatives in each of these
parametrisations for the optimiser (:mod:`.parity_optimiser`) and the
intervals (:mod:`.parity_intervals`).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["FringeCounts", "nll_polar", "nll_ab", "grad_hess_ab", "boundary_poles",
           "boundary_derivs", "phi_derivs", "dnll_dA"]


class FringeCounts:
    """A parity fringe's counts as the likelihood reads them: fringe angles theta = 2 phi,
    their cos/sin, even/odd counts."""

    __slots__ = ("theta", "c", "s", "k", "m", "n", "kpos", "mpos")

    def __init__(self, phases, k, n):
        self.theta = 2.0 * phases
        self.c = np.cos(self.theta)
        self.s = np.sin(self.theta)
        self.k = k
        self.n = n
        self.m = n - k
        self.kpos = k > 0
        self.mpos = self.m > 0


def _xlog(coef, x):
    """``coef * log(x)`` with 0 for coef == 0 (any x >= 0), inf-safe."""
    with np.errstate(divide="ignore", invalid="ignore"):
        out = coef * np.log(x)
    return np.where(coef == 0, 0.0, out)


def nll_polar(d: FringeCounts, A, phi0):
    """-lnL at (A, phi0); arrays broadcast against the data's last axis.

    +inf outside the domain (a p_i <= 0 or >= 1 against its counts, or p_i
    outside [0, 1]).
    """
    A = np.asarray(A, dtype=float)[..., None]
    phi0 = np.asarray(phi0, dtype=float)[..., None]
    t = A * np.cos(d.theta + phi0)
    p = 0.5 * (1.0 + t)
    q = 0.5 * (1.0 - t)
    val = -(_xlog(d.k, p) + _xlog(d.m, q)).sum(axis=-1)
    bad = ((p < 0) | (q < 0)).any(axis=-1)
    return np.where(bad | np.isnan(val), np.inf, val)


def nll_ab(d: FringeCounts, a, b) -> float:
    """-lnL at (a, b); +inf outside the domain.  Rounding below 0 (< 1e-13) counts as 0."""
    t = a * d.c + b * d.s
    p = 0.5 * (1.0 + t)
    q = 0.5 * (1.0 - t)
    pmin, qmin = p.min(), q.min()
    if pmin > 0 and qmin > 0:
        return float(-(d.k @ np.log(p) + d.m @ np.log(q)))
    if pmin < -1e-13 or qmin < -1e-13:
        return math.inf
    p, q = np.maximum(p, 0.0), np.maximum(q, 0.0)
    val = -float(np.sum(_xlog(d.k, p)) + np.sum(_xlog(d.m, q)))
    return val if not math.isnan(val) else math.inf


def grad_hess_ab(d: FringeCounts, a, b):
    """Gradient and Hessian of -lnL in (a, b).

    Terms with a zero count contribute nothing also where their p is 0.
    """
    t = a * d.c + b * d.s
    p = np.maximum(0.5 * (1.0 + t), 0.0)
    q = np.maximum(0.5 * (1.0 - t), 0.0)
    if p.min() > 0 and q.min() > 0:
        kp = d.k / p
        mq = d.m / q
        ht = 0.25 * (kp / p + mq / q)             # d2(-lnL)/dt_i^2
    else:
        zero = np.zeros_like(p)
        kp = np.divide(d.k, p, out=zero.copy(), where=d.kpos)
        mq = np.divide(d.m, q, out=zero.copy(), where=d.mpos)
        ht = 0.25 * (np.divide(kp, p, out=zero.copy(), where=d.kpos)
                     + np.divide(mq, q, out=zero.copy(), where=d.mpos))
    gt = -0.5 * (kp - mq)                         # d(-lnL)/dt_i
    g = np.array([gt @ d.c, gt @ d.s])
    hc = ht * d.c
    hs = ht * d.s
    H = np.array([[hc @ d.c, hc @ d.s], [hc @ d.s, hs @ d.s]])
    return g, H


# --- the circle A = 1 --------------------------------------------------------
def boundary_poles(d: FringeCounts) -> np.ndarray:
    """Sorted phi0 values in [0, 2pi) where -lnL(A = 1, phi0) has a pole."""
    poles = np.concatenate([np.mod(math.pi - d.theta[d.kpos], 2 * math.pi),
                            np.mod(-d.theta[d.mpos], 2 * math.pi)])
    return np.unique(poles)


def boundary_derivs(d: FringeCounts, phi0: float):
    """d/dphi0 and d2/dphi0^2 of -lnL(A = 1, phi0) and d(-lnL)/dA at A = 1."""
    h = 0.5 * (d.theta + phi0)                    # u/2
    ch, sh = np.cos(h), np.sin(h)
    k, m = d.k, d.m
    with np.errstate(divide="ignore", invalid="ignore"):
        tk = np.where(d.kpos, k * sh / ch, 0.0)                     # k tan(u/2)
        tm = np.where(d.mpos, m * ch / sh, 0.0)                     # m cot(u/2)
        d1 = float(np.sum(tk - tm))
        d2 = float(np.sum(np.where(d.kpos, 0.5 * k / ch ** 2, 0.0)
                          + np.where(d.mpos, 0.5 * m / sh ** 2, 0.0)))
        cu = ch * ch - sh * sh                                      # cos u
        dA = float(np.sum(np.where(d.kpos, -k * cu / (2 * ch * ch), 0.0)
                          + np.where(d.mpos, m * cu / (2 * sh * sh), 0.0)))
    return d1, d2, dA


# --- at fixed A -------------------------------------------------------------------
def phi_derivs(d: FringeCounts, A: float, phi0: float):
    """-lnL and its first two phi0-derivatives at fixed 0 < A < 1."""
    u = d.theta + phi0
    cu, su = np.cos(u), np.sin(u)
    Acu = A * cu
    P = 1.0 + Acu
    Q = 1.0 - Acu
    if not (P.min() > 0 and Q.min() > 0):
        return math.inf, 0.0, 0.0
    f = -float(d.k @ np.log(0.5 * P) + d.m @ np.log(0.5 * Q))
    kP, mQ = d.k / P, d.m / Q
    diff = kP - mQ
    d1 = A * float(su @ diff)
    d2 = float(Acu @ diff) + A * A * float((su * su) @ (kP / P + mQ / Q))
    return f, d1, d2


def dnll_dA(d: FringeCounts, A: float, phi0: float) -> float:
    """``d(-lnL)/dA`` at ``(A, phi0)``, ``|A| < 1``."""
    cu = np.cos(d.theta + phi0)
    return -float((d.k * cu) @ (1 / (1 + A * cu)) - (d.m * cu) @ (1 / (1 - A * cu)))
