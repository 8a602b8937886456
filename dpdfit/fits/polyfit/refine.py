"""Iterative refinement of the least-squares solution with double-double residuals.

Steps 3 and 4 of the method of :func:`~dpdfit.fits.polyfit.polyfit` (see
:mod:`dpdfit.fits.polyfit.fit`): the double QR factorisation ``Q R`` of the
high part of the column-scaled design serves as approximate solver for
Bjoerck's iterative refinement of the augmented system ::

    r + A x = b,     A^T r = g

whose residuals ``f = b - r - A x``, ``g' = g - A^T r`` are evaluated in
double-double (:mod:`dpdfit.fits.polyfit.double_double`) and whose
corrections ``h = R^-T g'``, ``dx = R^-1 (Q^T f - h)``,
``dr = f - Q (Q^T f - h)`` are accumulated into double-double ``x`` and
``r``.  The columns of ``(A^T A)^-1`` solve the same system with ``b = 0``,
``g = e_j`` (solution ``x = -(A^T A)^-1 e_j``) and are refined together with
the fit, as extra right-hand sides.

The refinement stops when every right-hand side's correction is below
``REFINE_RTOL = 1e-17`` of its solution (max-norms, scaled columns), or when
the corrections stop shrinking (noise floor).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from dpdfit.errors import FitError
from dpdfit.fits.polyfit import double_double as _dd

__all__ = ["solve_scaled", "ScaledSolution", "solve_upper", "REFINE_RTOL", "REFINE_MAX_ITER"]

#: Stop refining once every right-hand side's correction is below this
#: fraction of the largest component of its (column-scaled) solution.
REFINE_RTOL = 1e-17
#: Upper bound on refinement steps (each is one solve with the double QR).
REFINE_MAX_ITER = 60
#: Corrections that shrink by less than this factor per step have stagnated.
_STAGNATION_FACTOR = 0.5
#: A stagnated refinement still counts as converged if its last correction is
#: below double-precision resolution (the rounded double result is settled).
_STAGNATION_OK = np.finfo(np.float64).eps
#: A refinement that ends with a larger relative correction is a failure.
_FAIL_RTOL = 1e-6

#: Row-block size target (elements of an n x p x m temporary) for the dd
#: matrix products; bounds their memory for large n.
_BLOCK_ELEMENTS = 1 << 17


def _row_blocks(n: int, per_row: int):
    """Slices of at most ``_BLOCK_ELEMENTS // per_row`` rows covering ``range(n)``."""
    step = max(1, _BLOCK_ELEMENTS // max(per_row, 1))
    return [slice(i, min(i + step, n)) for i in range(0, n, step)]


def _dd_matmul(A, X):
    """dd ``A @ X`` for A (n x p) and X (p x m); products and sums in dd."""
    n, p = A[0].shape
    blocks = _row_blocks(n, p * X[0].shape[1])
    out_hi = np.empty((n, X[0].shape[1]))
    out_lo = np.empty_like(out_hi)
    for rows in blocks:
        prod = _dd.dd_mul((A[0][rows, :, None], A[1][rows, :, None]), (X[0][None], X[1][None]))
        out_hi[rows], out_lo[rows] = _dd.dd_sum(prod, axis=1)
    return out_hi, out_lo


def _dd_rmatmul(A, R):
    """dd ``A.T @ R`` for A (n x p) and R (n x m); pairwise sums over the n rows."""
    n, p = A[0].shape
    total = None
    for rows in _row_blocks(n, p * R[0].shape[1]):
        prod = _dd.dd_mul((A[0][rows, :, None], A[1][rows, :, None]),
                          (R[0][rows, None, :], R[1][rows, None, :]))
        part = _dd.dd_sum(prod, axis=0)
        total = part if total is None else _dd.dd_add(total, part)
    return total


def solve_upper(R: np.ndarray, B: np.ndarray, transpose: bool = False) -> np.ndarray:
    """Solve ``R X = B`` (or ``R^T X = B``) for upper-triangular R by substitution.

    A plain numpy loop over the p rows (p is small).  Deliberately not
    :func:`scipy.linalg.solve_triangular`: with a multi-threaded OpenBLAS its
    ``trsm`` can take milliseconds per call for a 4 x 4 matrix when the CPU is
    shared (thread hand-off), which would dominate the refinement loop.
    """
    p = R.shape[0]
    X = np.empty(np.shape(B))
    diag = np.diagonal(R)
    if transpose:                       # forward substitution with R^T (lower)
        for i in range(p):
            X[i] = (B[i] - R[:i, i] @ X[:i]) / diag[i]
    else:                               # back substitution with R
        for i in range(p - 1, -1, -1):
            X[i] = (B[i] - R[i, i + 1:] @ X[i + 1:]) / diag[i]
    return X


@dataclass
class _Refined:
    """Outcome of :func:`_refine_augmented` (dd solutions and refinement status)."""

    x: tuple          # dd (p x m)
    r: tuple          # dd (n x m)
    iterations: int
    converged: bool
    last_correction: float
    history: list = field(default_factory=list)


def _refine_augmented(A, Q, R, b, g) -> _Refined:
    """Iteratively refine ``r + A x = b, A^T r = g`` for m right-hand sides at once.

    Parameters
    ----------
    A : tuple of ndarray
        dd matrix (n x p), full column rank.
    Q, R : ndarray
        Thin double QR factors of (approximately) ``A``; the approximate solver.
    b, g : tuple of ndarray
        dd right-hand sides, (n x m) and (p x m).

    Returns
    -------
    _Refined
        ``x`` and ``r`` in dd, the number of corrections applied (including the
        first solve from ``x = r = 0``), whether the refinement converged and
        the history of relative corrections ``max_k ||dx_k|| / ||x_k||``
        (max-norms).
    """
    n, p = A[0].shape
    m = b[0].shape[1]
    x = _dd.dd(np.zeros((p, m)))
    r = _dd.dd(np.zeros((n, m)))
    history = []
    converged = False
    for it in range(1, REFINE_MAX_ITER + 1):
        if it == 1:                     # x = r = 0: the residuals are the rhs
            f, gp = b, g
        else:
            f = _dd.dd_sub(_dd.dd_sub(b, r), _dd_matmul(A, x))
            gp = _dd.dd_sub(g, _dd_rmatmul(A, r))
        f_d = _dd.dd_to_float(f)
        h = solve_upper(R, _dd.dd_to_float(gp), transpose=True)
        c = Q.T @ f_d - h
        dx = solve_upper(R, c)
        dr = f_d - Q @ c
        x = _dd.dd_add_d(x, dx)
        r = _dd.dd_add_d(r, dr)
        size = np.max(np.abs(x[0]), axis=0)
        step = np.max(np.abs(dx), axis=0)
        with np.errstate(invalid="ignore", divide="ignore"):
            rel = np.where(step == 0, 0.0, step / size)
        measure = float(np.max(rel)) if np.all(np.isfinite(rel)) else np.inf
        history.append(measure)
        if measure <= REFINE_RTOL:
            converged = True
            break
        if it > 1 and measure > _STAGNATION_FACTOR * history[-2]:
            converged = measure <= _STAGNATION_OK
            break
    return _Refined(x, r, it, converged, history[-1], history)


@dataclass
class ScaledSolution:
    """Least-squares solution in the column-scaled variables."""

    coefficients: np.ndarray      # x_s, (p,)
    gram_inv: np.ndarray          # (A_s^T A_s)^-1, (p, p), symmetric
    chi2: float                   # ||b_s - A_s x_s||^2
    iterations: int
    converged: bool


def solve_scaled(As, Q, R, bs, cond_scaled) -> ScaledSolution:
    """Refined solution, Gram inverse and residual sum of squares of ``As x = bs``.

    ``As`` is the column-scaled dd design, ``Q, R`` the double QR factors of
    its high part, ``bs`` the scaled dd right-hand side.
    The data column and the p unit vectors (for the Gram inverse) are refined
    together; FitError / RuntimeWarning when the refinement fails / falls short.
    """
    n, p = As[0].shape
    rhs_b = (np.zeros((n, p + 1)), np.zeros((n, p + 1)))
    rhs_b[0][:, 0], rhs_b[1][:, 0] = bs
    rhs_g = _dd.dd(np.hstack([np.zeros((p, 1)), np.eye(p)]))
    ref = _refine_augmented(As, Q, R, rhs_b, rhs_g)
    if not ref.converged:
        msg = (f"iterative refinement stopped after {ref.iterations} iteration(s) with "
               f"relative correction {ref.last_correction:.2g} (condition number "
               f"{cond_scaled:.3g} after column scaling)")
        if not ref.last_correction <= _FAIL_RTOL:
            raise FitError(msg + "; the design is too ill-conditioned")
        warnings.warn(msg + "; results are less accurate than usual", RuntimeWarning,
                      stacklevel=3)
    x = ref.x
    gram_inv = -_dd.dd_to_float((x[0][:, 1:], x[1][:, 1:]))
    # weighted residual of the refined solution in dd, and its sum of squares
    res = _dd.dd_sub((bs[0][:, None], bs[1][:, None]),
                     _dd_matmul(As, (x[0][:, :1], x[1][:, :1])))
    chi2 = float(_dd.dd_to_float(_dd.dd_dot(res, res, axis=0))[0])
    return ScaledSolution(
        coefficients=_dd.dd_to_float((x[0][:, 0], x[1][:, 0])),
        gram_inv=0.5 * (gram_inv + gram_inv.T), chi2=chi2,
        iterations=ref.iterations, converged=ref.converged)

