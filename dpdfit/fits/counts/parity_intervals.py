"""Errors and intervals of the parity contrast: Hessian, Fisher, profile likelihood (S7.2).

*Errors.*  ``A_err`` is the paper's: the inverse of the Hessian of ``-lnL``
in ``(A, phi0)`` from central finite differences with step 1e-5, after an
eigenvalue check of positive definiteness.  ``A_err_fisher`` is the
expected (Fisher) information at the optimum, ``I = sum n_i grad(p_i)
grad(p_i)^T / (p_i (1 - p_i))``, as a cross-check (it agrees with the
observed-information sigma to a few per cent when the fit is good).

*Boundary policy.*  The quadratic (Hessian) approximation of ``-lnL`` fails
when the contrast is within a few sigma of a physical boundary: near
``A = 1`` the likelihood is strongly skewed (the ``p_i`` of the fringe
extremes approach 0 and 1) and the MLE can sit on the boundary.  The
Hessian result (``method = "hessian"``, interval ``A -/+ z A_err``) is used
only when the Hessian is positive definite and ``A - BOUNDARY_SIGMAS *
A_err > 0`` and ``A + BOUNDARY_SIGMAS * A_err < 1`` (``BOUNDARY_SIGMAS =
3``).  Otherwise ``method = "profile"`` and ``flag`` says why: the interval
is the profile-likelihood interval ``{A : 2 [min_phi0 -lnL(A, phi0) -
min -lnL] <= chi2_1(level)}`` (``<= 1`` for 68.27 %), clipped to [0, 1], and
``A_err = max(A - A_lo, A_hi - A) / z`` (``z = 1`` at 68.27 %: the larger
one-sided distance, conservative as a symmetric error bar and never 0).  ``covariance``
is None in profile mode (the Hessian, if it could be computed, is kept in
``hessian``); ``phi0_err`` then is ``1/sqrt(d^2(-lnL)/dphi0^2)`` at the
optimum (conditional on A).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from dpdfit.errors import FitError, InputError

from .levels import normal_quantile
from .parity_likelihood import FringeCounts, boundary_derivs, dnll_dA, nll_polar, phi_derivs
from .parity_optimiser import boundary_minimum

__all__ = ["HESSIAN_FD_STEP", "BOUNDARY_SIGMAS", "parity_information", "ContrastErrors",
           "contrast_errors", "fisher_error"]

#: Finite-difference step of the Hessian of -lnL in (A, phi0) (as the paper).
HESSIAN_FD_STEP = 1e-5
#: Hessian intervals are used only when A is more than this many sigma inside (0, 1).
BOUNDARY_SIGMAS = 3.0


# --- derivatives in (A, phi0) ---------------------------------------------------
def _fd_hessian(d: FringeCounts, A: float, phi0: float, h: float = HESSIAN_FD_STEP):
    """Central finite-difference Hessian of -lnL in (A, phi0), step h (9 evaluations)."""
    dA = np.array([0, 1, -1, 0, 0, 1, 1, -1, -1]) * h
    dp = np.array([0, 0, 0, 1, -1, 1, -1, 1, -1]) * h
    f = nll_polar(d, A + dA, phi0 + dp)
    if not np.all(np.isfinite(f)):
        return None
    haa = (f[1] - 2 * f[0] + f[2]) / h ** 2
    hpp = (f[3] - 2 * f[0] + f[4]) / h ** 2
    hap = (f[5] - f[6] - f[7] + f[8]) / (4 * h * h)
    return np.array([[haa, hap], [hap, hpp]])


def _fisher_information(theta, n, A, phi0):
    """Expected (Fisher) information in (A, phi0); None if some p is 0 or 1."""
    u = theta + phi0
    cu, su = np.cos(u), np.sin(u)
    pq = 0.25 * (1 - A * cu) * (1 + A * cu)       # p (1 - p)
    if np.any(pq <= 0):
        return None
    w = n / pq
    ga = 0.5 * cu                                 # dp/dA
    gp = -0.5 * A * su                            # dp/dphi0
    return np.array([[w @ (ga * ga), w @ (ga * gp)], [w @ (ga * gp), w @ (gp * gp)]])


def parity_information(phases, shots, A, phi0) -> np.ndarray:
    """Fisher information matrix in (A, phi0) of a parity scan (2 x 2).

    ``I = sum_i n_i grad(p_i) grad(p_i)^T / (p_i (1 - p_i))`` with
    ``p_i = (1 + A cos(2 phi_i + phi0)) / 2``; ``sqrt(inv(I)[0, 0])`` is the
    Cramer-Rao bound on the error of A (e.g. for planning a scan, or to
    judge a fit's ``A_err``).  Raises InputError when some ``p_i`` is 0 or 1
    (infinite information).
    """
    phases = np.atleast_1d(np.asarray(phases, dtype=float))
    n = np.broadcast_to(np.asarray(shots, dtype=float), phases.shape)
    info = _fisher_information(2 * phases, n, float(A), float(phi0))
    if info is None:
        raise InputError("some p_i is exactly 0 or 1 at these parameters: the information "
                         "is infinite")
    return info


def _profile_at(d: FringeCounts, A: float, phi_start: float):
    """min over phi0 of -lnL at fixed A: ``(nll, phi0, dnll/dA)``.

    Newton's method in phi0 from ``phi_start`` (the optimum's phase, or the
    previous A's), with backtracking; gradient steps where the curvature is
    not positive.  The phase converges to ~1e-9 rad (the profile value then
    is exact to ~1e-14 relative).
    """
    if A >= 1.0:
        sol = boundary_minimum(d, phi_start)
        if sol is None:
            return math.inf, phi_start, 0.0
        return sol[1], sol[0], sol[2]
    if A <= 0.0:
        return float(d.n.sum() * math.log(2.0)), phi_start, dnll_dA(d, 0.0, phi_start)
    x = phi_start
    f, d1, d2 = phi_derivs(d, A, x)
    for _ in range(100):
        step = -d1 / d2 if d2 > 0 else -math.copysign(0.1, d1)
        step = max(-0.5, min(0.5, step))
        if abs(step) < 1e-9:
            x += step
            break
        t = 1.0
        slack = 64 * np.finfo(float).eps * abs(f)        # rounding level of -lnL
        while True:
            fn, d1n, d2n = phi_derivs(d, A, x + t * step)
            if fn <= f + 1e-4 * t * step * d1 + slack or t < 1e-10:
                break
            t *= 0.5
        x, f, d1, d2 = x + t * step, fn, d1n, d2n
    return f, x, dnll_dA(d, A, x)


def _profile_root(d, target, A_in, A_out, f_out, phi_out, dfdA_out):
    """A between A_in (profile below target) and A_out (profile f_out above it).

    Safeguarded Newton from A_out (dP/dA = d(-lnL)/dA at the profiled phi0,
    envelope theorem) with bisection fallback; |dA| < 1e-10 at the end.
    """
    lo, hi = A_in, A_out                          # g < 0 at lo, g > 0 at hi
    x, phi, dfdA = A_out, phi_out, dfdA_out
    g = f_out - target
    for _ in range(100):
        if g > 0:
            hi = x
        else:
            lo = x
        xn = x - g / dfdA if dfdA != 0 and math.isfinite(dfdA) and math.isfinite(g) else math.nan
        if not (min(lo, hi) < xn < max(lo, hi)):
            xn = 0.5 * (lo + hi)
        if abs(xn - x) < 1e-10:
            x = xn
            break
        x = xn
        f, phi, dfdA = _profile_at(d, x, phi)
        g = f - target
    return float(x)


def _profile_interval(d: FringeCounts, A_hat, phi_hat, f_min, level, scale):
    """Profile-likelihood interval of A at ``level`` (2 Delta(-lnL) <= z^2), clipped to [0, 1].

    The profile ``P(A) = min_phi0 -lnL(A, phi0)`` is non-increasing below
    the MLE and non-decreasing above it (convexity in (a, b)), so each end
    is a single crossing: bracketed by steps of 1.5, 3, 6, ... ``scale``
    from the MLE, then solved by safeguarded Newton.
    """
    target = f_min + 0.5 * normal_quantile(level) ** 2
    step0 = 1.5 * max(scale, 1e-6)
    # lower end
    if float(d.n.sum() * math.log(2.0)) <= target:      # -lnL at A = 0
        A_lo = 0.0
    else:
        step, A_in = step0, A_hat
        while True:
            trial = max(A_hat - step, 0.0)
            out = _profile_at(d, trial, phi_hat)
            if out[0] > target:
                A_lo = _profile_root(d, target, A_in, trial, *out)
                break
            A_in = trial
            step *= 2
    # upper end
    if A_hat >= 1.0:
        A_hi = 1.0
    else:
        out1 = _profile_at(d, 1.0, phi_hat)
        if not out1[0] > target:
            A_hi = 1.0
        else:
            step, A_in = step0, A_hat
            while True:
                trial = A_hat + step
                if trial >= 1.0:
                    A_hi = _profile_root(d, target, A_in, 1.0, *out1)
                    break
                out = _profile_at(d, trial, phi_hat)
                if out[0] > target:
                    A_hi = _profile_root(d, target, A_in, trial, *out)
                    break
                A_in = trial
                step *= 2
    return min(A_lo, A_hat), max(A_hi, A_hat)


# --- the boundary policy -----------------------------------------------------------
class ContrastErrors(NamedTuple):
    """Errors of (A, phi0) by the method the boundary policy chose."""

    method: str                     # "hessian" or "profile"
    A_err: float
    phi0_err: float
    A_lo: float
    A_hi: float
    covariance: np.ndarray | None   # inverse Hessian (hessian method only)
    hessian: np.ndarray | None      # finite-difference Hessian, when it could be evaluated
    reasons: list                   # why the profile was used (empty for the Hessian)


def fisher_error(d: FringeCounts, A: float, phi0: float):
    """``(sqrt([I^-1]_AA), note)`` from the expected information at the optimum.

    The error is NaN, and ``note`` says why, when the information is infinite
    (some ``p_i`` is 0 or 1) or singular.
    """
    info = _fisher_information(d.theta, d.n, A, phi0)
    A_err_fisher = math.nan
    if info is not None:
        try:
            cf = np.linalg.inv(info)
            if cf[0, 0] > 0:
                A_err_fisher = math.sqrt(cf[0, 0])
        except np.linalg.LinAlgError:
            pass
    if np.isfinite(A_err_fisher):
        return A_err_fisher, None
    return A_err_fisher, ("Fisher cross-check undefined (some p_i is 0 or 1 at the optimum: "
                          "infinite information)" if info is None
                          else "Fisher information singular (A = 0?)")


def _hessian_errors(d: FringeCounts, A: float, phi0: float):
    """The paper's errors from the finite-difference Hessian.

    Returns ``(H, cov, A_err, phi0_err, problem)``; ``cov`` is None and the
    errors NaN, with ``problem`` saying why, when the stencil leaves the domain
    or the Hessian is not positive definite (``H`` is None in the first case).
    """
    Hfd = _fd_hessian(d, A, phi0)
    if Hfd is None:
        return (None, None, math.nan, math.nan,
                "the finite-difference Hessian stencil (step 1e-5) leaves the domain "
                "|A| <= 1 / 0 < p_i < 1")
    eig = np.linalg.eigvalsh(Hfd)
    if not (eig[0] > 1e-10 * abs(eig[-1]) and np.all(np.isfinite(eig))):
        return (Hfd, None, math.nan, math.nan,
                f"Hessian not positive definite (eigenvalues {eig[0]:.3g}, {eig[1]:.3g})")
    cov = np.linalg.inv(Hfd)
    return Hfd, cov, math.sqrt(cov[0, 0]), math.sqrt(cov[1, 1]), None


def _profile_reasons(A: float, A_err_h: float, on_boundary: bool, problem) -> list:
    """Why the Hessian interval is not used (empty list: it is); see the boundary policy."""
    reasons = [problem] if problem else []
    if on_boundary:
        reasons.insert(0, "MLE on the physical boundary A = 1")
    elif problem is None:
        if A + BOUNDARY_SIGMAS * A_err_h >= 1.0:
            reasons.append(f"A is within {BOUNDARY_SIGMAS:g} sigma of the boundary A = 1 "
                           f"((1 - A)/sigma_Hessian = {(1 - A) / A_err_h:.2f}): the quadratic "
                           "approximation of -lnL fails there")
        elif A - BOUNDARY_SIGMAS * A_err_h <= 0.0:
            reasons.append(f"A is within {BOUNDARY_SIGMAS:g} sigma of 0 (A/sigma_Hessian = "
                           f"{A / A_err_h:.2f}): the polar quadratic approximation fails there")
    return reasons


def contrast_errors(d: FringeCounts, A: float, phi0: float, f_min: float, level: float,
                     on_boundary: bool, A_err_fisher: float) -> ContrastErrors:
    """Errors and interval of A at the optimum, by the boundary policy (module docstring)."""
    z = normal_quantile(level)
    Hfd, cov, A_err_h, phi0_err_h, problem = _hessian_errors(d, A, phi0)
    reasons = _profile_reasons(A, A_err_h, on_boundary, problem)
    if not reasons:
        A_lo, A_hi = max(A - z * A_err_h, 0.0), min(A + z * A_err_h, 1.0)
        return ContrastErrors("hessian", A_err_h, phi0_err_h, A_lo, A_hi, cov, Hfd, reasons)
    scale = next((s for s in (A_err_h, A_err_fisher) if np.isfinite(s) and s > 0),
                 0.5 / math.sqrt(d.n.sum()))
    A_lo, A_hi = _profile_interval(d, A, phi0, f_min, level, scale)
    A_err = max(A - A_lo, A_hi - A) / z
    if on_boundary:
        _, d2, _ = boundary_derivs(d, phi0)
    else:
        _, _, d2 = phi_derivs(d, A, phi0)
    phi0_err = 1.0 / math.sqrt(d2) if d2 > 0 else math.inf
    if not A_err > 0:                             # cannot happen for finite data; guard
        raise FitError("profile-likelihood interval of A has zero width")
    return ContrastErrors("profile", A_err, phi0_err, A_lo, A_hi, None, Hfd, reasons)
