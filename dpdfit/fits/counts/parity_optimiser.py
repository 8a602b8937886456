"""Maximum-likelihood optimiser of a parity fringe on the disk ``|A| <= 1`` (S7.2).

In ``(a, b) = (A cos phi0, -A sin phi0)`` the probabilities are
linear, ``p_i = (1 + a cos 2phi_i + b sin 2phi_i) / 2``, so ``-lnL`` is
convex and the feasible set ``a^2 + b^2 <= 1`` is a disk (on which every
``p_i`` lies in [0, 1]).  Start: weighted linear least squares of the
measured parity ``2 k_i/n_i - 1`` (radius capped at 0.99).  Then Newton
steps with the analytic gradient and Hessian whose quadratic model is
minimised *on the disk* (the plain Newton step when it stays inside,
otherwise the model's KKT point on the circle from its 2 x 2 secular
equation), with Armijo backtracking; every trial point is feasible (the disk
is convex) and points where some ``p_i`` is 0 against its counts have
``-lnL = inf`` and are rejected.  Iteration stops when the model decrease
``-g.s`` (the squared Newton decrement in the interior) is below 1e-14 or
the rounding level of ``-lnL`` -- the parameters are then within ~1e-7
sigma of the optimum.  Plain interior Newton with a fraction-to-boundary
rule is *not* enough: it can jam against the circle when the optimum is
interior but the model points outward.  An optimum on the circle is
polished by a 1-D solve on ``A = 1``, where ``-lnL(phi0) = -sum 2 k_i
ln|cos(u_i/2)| + 2 (n_i - k_i) ln|sin(u_i/2)|`` (``u_i = 2 phi_i + phi0``)
is strictly convex between its poles (where a ``p_i`` would be 0 against
counts that say otherwise): a bracketed Newton solve on the arc, accepted
when ``d(-lnL)/dA <= 0`` there (KKT: the likelihood still rises outward),
which makes it the global constrained optimum.  The MLE then sits on the
boundary ``A = 1`` (``on_boundary``; some ``p_i`` may be exactly 0 or 1
where the counts are all-even or all-odd).  The result is reported with
``A >= 0`` and ``phi0`` in (-pi, pi].  Checked against multi-start SLSQP on
1500 random data sets (3-16 phases, 1-700 shots, contrasts 0-1, perfect
fringes): never worse, within 2e-12 in ``-lnL``.
"""

from __future__ import annotations

import math

import numpy as np

from .parity_likelihood import (FringeCounts, boundary_derivs, boundary_poles, grad_hess_ab,
                                nll_ab, nll_polar)

__all__ = ["optimise", "boundary_minimum"]

_NEWTON_TOL = 1e-14         # model decrease -g.s (Newton decrement^2) at convergence
_MAX_NEWTON = 100


def _disk_step(x, g, H):
    """Minimiser s of the model g.s + s.H.s/2 subject to |x + s| <= 1 (H positive definite).

    The Newton step when it stays in the disk; otherwise the point y = x + s
    on the circle with (H + lam I) y = H x - g, lam > 0 (KKT of the model),
    found by Newton's method on the secular equation 1/|y(lam)| = 1.
    """
    try:
        s = -np.linalg.solve(H, g)
    except np.linalg.LinAlgError:
        s = None
    if s is not None and np.all(np.isfinite(s)):
        y = x + s
        if y @ y <= 1.0:
            return s
    h, Q = np.linalg.eigh(H)
    w = Q.T @ (H @ x - g)
    w2 = w * w
    # |y(lam)| = |w / (h + lam)| decreases from > 1 at lam = 0 to <= 1 at lam = |w| - h_min
    lam = 0.0 if h[0] > 0 else -h[0] + 1e-12 * max(abs(h[1]), 1.0)
    lo, hi = lam, max(lam, math.sqrt(float(w2.sum())) - h[0]) + 1e-300
    for _ in range(60):
        den = h + lam
        ny2 = float(np.sum(w2 / den ** 2))
        ny = math.sqrt(ny2)
        psi = 1.0 / ny - 1.0
        if psi < 0:
            lo = lam
        else:
            hi = lam
        dpsi = float(np.sum(w2 / den ** 3)) / (ny2 * ny)
        new = lam - psi / dpsi if dpsi > 0 else 0.5 * (lo + hi)
        if not lo <= new <= hi:
            new = 0.5 * (lo + hi)
        if abs(new - lam) <= 1e-15 * max(lam, 1.0) or abs(psi) < 1e-15:
            lam = new
            break
        lam = new
    y = Q @ (w / (h + lam))
    ny = math.sqrt(float(y @ y))
    if ny > 1.0:
        y = y / ny
    return y - x


# --- the circle A = 1 --------------------------------------------------------
def boundary_minimum(d: FringeCounts, phi_start: float):
    """Minimum of -lnL on the circle A = 1 in the pole-free arc containing phi_start.

    Returns ``(phi0, nll, dnll_dA)`` or None when the arc is degenerate.
    Between poles -lnL(phi0) is strictly convex and its derivative runs
    from -inf to +inf, so a bracketed Newton iteration finds the minimum.
    """
    poles = boundary_poles(d)
    x = phi_start % (2 * math.pi)
    j = int(np.searchsorted(poles, x, side="right"))
    lo = poles[j - 1] if j > 0 else poles[-1] - 2 * math.pi
    hi = poles[j] if j < poles.size else poles[0] + 2 * math.pi
    if x <= lo or x >= hi:                        # start exactly on a pole
        x = 0.5 * (lo + hi)
    if not hi - lo > 1e-12:
        return None
    for _ in range(200):
        d1, d2, _ = boundary_derivs(d, x)
        if d1 > 0:
            hi = min(hi, x)
        else:
            lo = max(lo, x)
        step = -d1 / d2 if d2 > 0 and np.isfinite(d1) else np.nan
        xn = x + step
        if not (lo < xn < hi):
            xn = 0.5 * (lo + hi)
        if abs(xn - x) <= 1e-13 * max(1.0, abs(x)) or hi - lo <= 1e-15:
            x = xn
            break
        x = xn
    _, _, dA = boundary_derivs(d, x)
    return x, float(nll_polar(d, 1.0, x)), dA


# --- the optimiser -------------------------------------------------------------
def _start(d: FringeCounts):
    """Weighted linear least squares of the parity 2 k/n - 1 on (cos, sin)."""
    y = 2.0 * d.k / d.n - 1.0
    w = d.n
    M = np.array([[w @ (d.c * d.c), w @ (d.c * d.s)], [w @ (d.c * d.s), w @ (d.s * d.s)]])
    v = np.array([w @ (y * d.c), w @ (y * d.s)])
    a, b = np.linalg.solve(M, v)
    r = math.hypot(a, b)
    if r > 0.99:
        a, b = a * 0.99 / r, b * 0.99 / r
    elif r < 1e-3:                                # avoid the polar origin as a start
        a, b = 1e-3, 0.0
    return float(a), float(b)


def optimise(d: FringeCounts):
    """MLE of (a, b) on the disk a^2 + b^2 <= 1 (convex problem).

    Newton steps whose quadratic model is minimised *on the disk*
    (:func:`_disk_step`), Armijo backtracking (every trial point is feasible
    because the disk is convex; points where a p_i = 0 against its counts
    have -lnL = inf and are rejected).  Stops when the model decrease
    ``-g.s`` is below ``_NEWTON_TOL``.  An optimum on (or within 1e-9 of)
    the circle is polished by the 1-D solve on A = 1 and accepted there when
    the KKT condition ``d(-lnL)/dA <= 0`` holds.

    Returns ``(a, b, nll, converged, iterations, on_boundary)``.
    """
    a, b = _start(d)
    x = np.array([a, b])
    f = nll_ab(d, a, b)
    converged = False
    it = 0
    for it in range(1, _MAX_NEWTON + 1):
        g, H = grad_hess_ab(d, x[0], x[1])
        s = _disk_step(x, g, H)
        dec = float(-(g @ s))
        resolution = 64 * np.finfo(float).eps * max(1.0, abs(f))
        if not dec > max(_NEWTON_TOL, resolution):
            # the quadratic model is exact to rounding here: take the last full step
            xn = x + s
            fn = nll_ab(d, xn[0], xn[1])
            if fn <= f + resolution:
                x, f = xn, fn
            converged = True
            break
        t = 1.0
        while True:
            xn = x + t * s
            fn = nll_ab(d, xn[0], xn[1])
            if fn <= f - 1e-4 * t * dec:
                break
            t *= 0.5
            if t < 1e-14:
                break
        if t < 1e-14:
            converged = dec < 1e-9          # no decrease left at double precision
            break
        x, f = xn, fn
    a, b = float(x[0]), float(x[1])
    on_boundary = False
    if a * a + b * b > (1.0 - 1e-9) ** 2:
        sol = boundary_minimum(d, math.atan2(-b, a))
        if sol is not None and np.isfinite(sol[1]) and sol[1] <= f + 1e-12 * max(1.0, abs(f)) \
                and sol[2] <= 0:
            phi_b, f, _ = sol
            a, b = math.cos(phi_b), -math.sin(phi_b)
            on_boundary = True
            converged = True
    return a, b, f, converged, it, on_boundary
