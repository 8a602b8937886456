"""The master equation's integration compiled (numba): the same DOP853 steps as scipy's.

:func:`~dpdfit.models.gate_sim.integrators.integrate_lindblad` steps
:class:`scipy.integrate.DOP853` by hand around a numpy right-hand side.  At the sizes
the diagnosis runs (two ions, ``n_fock`` 15-21: a state of ~5e3 complex numbers, ~200
right-hand sides per integration) most of the time is per-call overhead: numpy's
per-operation cost in the right-hand side (~160 us a call, of which the arithmetic is a
few tens) and scipy's Python step loop (a quarter to a third of an integration).  No
library integrates a compiled right-hand side without that loop (QuTiP 5's ``mesolve``
on the same problem is slower still), so both are compiled here, by hand:

* :func:`lindblad_rhs`: ``-i [H, rho]`` plus the dephasing and heating dissipator, the
  same terms as the reference's right-hand side (loops instead of array operations);
* :func:`dop853_lindblad`: scipy's DOP853 algorithm step for step -- its tableau (read
  from :class:`scipy.integrate.DOP853`), its initial step, its error norm (the 3rd/5th
  order blend), its step-size control (safety 0.9, factors 0.2-10, no increase after a
  rejection), its dense output (three more stages) at requested times between steps --
  so that the states agree with the reference to rounding (``tests/models``
  test_compiled_lindblad checks it over the diagnosis's parameter ranges).

Compiled on first use and cached on disk (``cache=True``, in ``__pycache__`` beside
this file); numba is imported only then, not with :mod:`dpdfit`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from scipy.integrate import DOP853

__all__ = ["lindblad_rhs", "dop853_lindblad", "TABLEAU"]


def _stage_tables():
    """scipy's DOP853 tableau (public class attributes) as the compiled loop reads it:
    for every stage ``s`` after the first -- the twelve of a step, the new state (the
    weights ``B``), the dense output's three -- the rows and coefficients of its nonzero
    terms and its time fraction; then the two error estimators and the interpolant's
    ``D``."""
    A, B, C = DOP853.A, DOP853.B, DOP853.C
    n_st = B.size
    n_ext = n_st + 1 + DOP853.A_EXTRA.shape[0]      # and the new state's derivative
    rows = np.zeros((n_ext, n_ext), dtype=np.int64)
    coefs = np.zeros((n_ext, n_ext))
    counts = np.zeros(n_ext, dtype=np.int64)
    frac = np.zeros(n_ext)
    for s in range(1, n_ext):
        row = (A[s, :s] if s < n_st else B if s == n_st
               else DOP853.A_EXTRA[s - n_st - 1, :s])
        nz = np.flatnonzero(row)
        rows[s, :nz.size], coefs[s, :nz.size], counts[s] = nz, row[nz], nz.size
        frac[s] = C[s] if s < n_st else 1.0 if s == n_st else DOP853.C_EXTRA[s - n_st - 1]
    return (rows, coefs, counts, frac, np.ascontiguousarray(DOP853.E3, dtype=float),
            np.ascontiguousarray(DOP853.E5, dtype=float),
            np.ascontiguousarray(DOP853.D, dtype=float))


#: the tableau of scipy's DOP853, as :func:`_stage_tables` arranges it
TABLEAU = _stage_tables()
#: stages of a step (the last one's state is the step's result)
_N_STAGES = int(DOP853.B.size)

_SAFETY, _MIN_FACTOR, _MAX_FACTOR = 0.9, 0.2, 10.0
_ERROR_EXPONENT = -1.0 / 8.0          # DOP853's error estimator is of order 7


@njit(cache=True)
def lindblad_rhs(tau, y, out, d, N, b, cc, w, beta_at, gam_at, diag, heat, sq, A):
    """``out = d rho / d tau`` for the flat state ``y`` (``rho`` of shape (d, N, d, N));
    ``A`` is scratch of ``y``'s size.  ``b, cc, w``: the drive's scaled blue amplitudes,
    conjugated red amplitudes and ``-2 pi i n``; ``beta_at, gam_at``: where ``beta`` and
    ``gamma`` enter ``K`` (flat indices); ``diag``: the dissipator's diagonal (flat);
    ``heat``: the heating rate; ``sq``: ``sqrt(0..N-1)``."""
    beta = 0j
    gam = 0j
    for m in range(w.size):
        e = np.exp(w[m] * tau)
        beta += b[m] * e
        gam += cc[m] * e
    mK = np.zeros(d * d, dtype=np.complex128)       # -i K: what acts left of a^dag rho
    mKd = np.zeros(d * d, dtype=np.complex128)      # -i K^dag: left of a rho
    for q in range(beta_at.size):
        mK[beta_at[q]] = beta
        mK[gam_at[q]] = -gam
        mKd[gam_at[q]] = -np.conj(beta)
        mKd[beta_at[q]] = np.conj(gam)
    DN = d * N
    # A = -i H rho, H = K a^dag + K^dag a (rows (i, k), columns flat (j, l))
    for i in range(d):
        for k in range(N):
            row = (i * N + k) * DN
            for J in range(DN):
                A[row + J] = 0j
            for ip in range(d):
                if k >= 1:
                    c = mK[i * d + ip] * sq[k]
                    if c != 0j:
                        src = (ip * N + k - 1) * DN
                        for J in range(DN):
                            A[row + J] += c * y[src + J]
                if k <= N - 2:
                    c = mKd[i * d + ip] * sq[k + 1]
                    if c != 0j:
                        src = (ip * N + k + 1) * DN
                        for J in range(DN):
                            A[row + J] += c * y[src + J]
    # -i [H, rho] = A + A^dag, plus the dissipator's diagonal
    for r in range(DN):
        for s in range(DN):
            out[r * DN + s] = (A[r * DN + s] + np.conj(A[s * DN + r])
                               + diag[r * DN + s] * y[r * DN + s])
    if heat != 0.0:
        # the heating jumps a rho a^dag and a^dag rho a, on rows and columns of the same
        # spin label (k, l the Fock levels of row r and column s)
        for r in range(DN):
            k = r % N
            for s in range(DN):
                l = s % N
                v = 0j
                if k <= N - 2 and l <= N - 2:
                    v += sq[k + 1] * sq[l + 1] * y[(r + 1) * DN + s + 1]
                if k >= 1 and l >= 1:
                    v += sq[k] * sq[l] * y[(r - 1) * DN + s - 1]
                out[r * DN + s] += heat * v


@njit(cache=True)
def _top(y, d, N):
    """Population of the top Fock level (what the reference's ``top_of`` returns)."""
    DN = d * N
    s = 0.0
    for i in range(d):
        r = i * N + N - 1
        s += y[r * DN + r].real
    return s


@njit(cache=True)
def _rms(x):
    return math.sqrt(np.sum(x.real ** 2 + x.imag ** 2) / x.size)


@njit(cache=True)
def _f(t, y, out, drv):
    """The right-hand side on float views; ``drv``: :func:`lindblad_rhs`'s arguments
    after ``out`` (a tuple)."""
    d, N, b, cc, w, beta_at, gam_at, diag, heat, sq, scratch = drv
    lindblad_rhs(t, y.view(np.complex128), out.view(np.complex128), d, N, b, cc, w,
                 beta_at, gam_at, diag, heat, sq, scratch)


@njit(cache=True)
def _stage(s, t, h, y, K, tab, drv, out):
    """Stage ``s`` of the step from ``(t, y)`` of size ``h``: ``out = y + h sum_r a_sr
    K[r]`` (float views, the tableau's nonzero terms), then ``K[s] = f(t + c_s h, out)``
    (for ``s`` the step's last stage ``out`` is the new state)."""
    rows, coefs, counts, frac = tab[0], tab[1], tab[2], tab[3]
    m = y.size
    c = counts[s]
    r0 = rows[s, 0]
    for q in range(m):
        out[q] = coefs[s, 0] * K[r0, q]
    for r in range(1, c):
        rr = rows[s, r]
        a = coefs[s, r]
        for q in range(m):
            out[q] += a * K[rr, q]
    for q in range(m):
        out[q] = y[q] + h * out[q]
    _f(t + frac[s] * h, out, K[s], drv)


@njit(cache=True)
def _weighted(K, coefs, out):
    """``out = sum_r coefs[r] K[r]`` over the first ``len(coefs)`` rows."""
    m = out.size
    for q in range(m):
        out[q] = coefs[0] * K[0, q]
    for r in range(1, coefs.size):
        a = coefs[r]
        if a != 0.0:
            for q in range(m):
                out[q] += a * K[r, q]


@njit(cache=True)
def _initial_step(y, f, t_bound, rtol, atol, drv):
    """scipy's ``select_initial_step`` (error estimator of order 7)."""
    yc = y.view(np.complex128)
    fc = f.view(np.complex128)
    scale = atol + np.abs(yc) * rtol
    d0 = _rms(yc / scale)
    d1 = _rms(fc / scale)
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    h0 = min(h0, t_bound)
    f1 = np.empty_like(f)
    _f(h0, (yc + h0 * fc).view(np.float64), f1, drv)
    d2 = _rms((f1.view(np.complex128) - fc) / scale) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    return min(100 * h0, h1, t_bound)


@njit(cache=True)
def _error_norm(y, y_new, K, h, rtol, atol, tab, err5, err3):
    """scipy's ``DOP853._estimate_error_norm``: the two estimators' sums (float views),
    then their squares scaled by ``atol + rtol max(|y|, |y_new|)``."""
    _weighted(K, tab[5], err5)
    _weighted(K, tab[4], err3)
    e5 = 0.0
    e3 = 0.0
    for q in range(y.size // 2):
        ya = math.hypot(y[2 * q], y[2 * q + 1])
        yb = math.hypot(y_new[2 * q], y_new[2 * q + 1])
        sc = atol + max(ya, yb) * rtol
        sc2 = sc * sc
        e5 += (err5[2 * q] ** 2 + err5[2 * q + 1] ** 2) / sc2
        e3 += (err3[2 * q] ** 2 + err3[2 * q + 1] ** 2) / sc2
    if e5 == 0.0 and e3 == 0.0:
        return 0.0
    return abs(h) * e5 / math.sqrt((e5 + 0.01 * e3) * (y.size // 2))


@njit(cache=True)
def _step(t, y, f, h_abs, t_bound, rtol, atol, K, tab, drv, dy, y_new, err5, err3):
    """One accepted step of scipy's ``RungeKutta._step_impl`` from ``(t, y)``, ``f`` its
    derivative: ``(t_new, h, next h_abs, attempts)`` with ``y_new`` and ``K`` filled;
    ``h = 0`` when the step fell below its minimum."""
    min_step = 10 * abs(np.nextafter(t, np.inf) - t)
    h_abs = max(h_abs, min_step)
    rejected = False
    attempts = 0
    K[0, :] = f
    while True:
        if h_abs < min_step:
            return t, 0.0, h_abs, attempts
        attempts += 1
        t_new = min(t + h_abs, t_bound)
        h = t_new - t
        h_abs = abs(h)
        for s in range(1, _N_STAGES):
            _stage(s, t, h, y, K, tab, drv, dy)
        _stage(_N_STAGES, t, h, y, K, tab, drv, y_new)
        err = _error_norm(y, y_new, K, h, rtol, atol, tab, err5, err3)
        if err < 1:
            factor = _MAX_FACTOR if err == 0 else min(_MAX_FACTOR,
                                                      _SAFETY * err ** _ERROR_EXPONENT)
            if rejected:
                factor = min(1.0, factor)
            return t_new, h, h_abs * factor, attempts
        h_abs *= max(_MIN_FACTOR, _SAFETY * err ** _ERROR_EXPONENT)
        rejected = True


@njit(cache=True)
def _dense(ts, t_old, h, y_old, f_old, y, f, K, tab, drv, dy, F, out):
    """scipy's DOP853 dense output over the last step (three more stages, a degree-7
    interpolant), evaluated at the times ``ts`` into the float rows ``out``."""
    for s in range(_N_STAGES + 1, K.shape[0]):
        _stage(s, t_old, h, y_old, K, tab, drv, dy)
    m = y.size
    for q in range(m):
        delta = y[q] - y_old[q]
        F[0, q] = delta
        F[1, q] = h * f_old[q] - delta
        F[2, q] = 2 * delta - h * (f[q] + f_old[q])
    D = tab[6]
    for p in range(D.shape[0]):
        _weighted(K, D[p], F[3 + p])
        for q in range(m):
            F[3 + p, q] *= h
    for jj in range(ts.size):
        x = (ts[jj] - t_old) / h
        for q in range(m):
            v = 0.0
            for k7 in range(F.shape[0]):
                v += F[F.shape[0] - 1 - k7, q]
                v *= x if k7 % 2 == 0 else 1 - x
            out[jj, q] = v + y_old[q]


@njit(cache=True)
def dop853_lindblad(y0, ts, rtol, atol, d, N, b, cc, w, beta_at, gam_at, diag, heat, tab):
    """States at the increasing times ``ts`` (all > 0) from ``y0`` at 0, the largest
    top-level population after any step, and the right-hand sides evaluated:
    ``(ys (len(ts), n), top, nfev)``; ``nfev = -1``: the step size fell below its
    minimum (scipy's "too small step"); ``-2``: the last time was not reached.
    ``tab``: :data:`TABLEAU`."""
    n = y0.size
    m = 2 * n
    drv = (d, N, b, cc, w, beta_at, gam_at, diag, heat,
           np.sqrt(np.arange(N).astype(np.float64)), np.empty(n, dtype=np.complex128))
    K = np.empty((tab[0].shape[0], m))
    ys = np.empty((ts.size, n), dtype=np.complex128)
    out = ys.view(np.float64)
    y = y0.copy().view(np.float64)
    f = np.empty(m)
    _f(0.0, y, f, drv)
    h_abs = _initial_step(y, f, ts[-1], rtol, atol, drv)
    nfev = 2
    top = _top(y.view(np.complex128), d, N)
    dy, y_new, y_old, f_old = np.empty(m), np.empty(m), np.empty(m), np.empty(m)
    err5, err3 = np.empty(m), np.empty(m)
    F = np.empty((tab[6].shape[0] + 3, m))
    t = 0.0
    i = 0
    while i < ts.size:
        t_old = t
        t, h, h_abs, attempts = _step(t, y, f, h_abs, ts[-1], rtol, atol, K, tab, drv, dy,
                                      y_new, err5, err3)
        if h == 0.0:
            return ys, top, -1
        nfev += _N_STAGES * attempts
        y_old[:] = y
        f_old[:] = f
        y[:] = y_new
        f[:] = K[_N_STAGES]
        j = i
        while j < ts.size and ts[j] <= t:
            j += 1
        if j > i:
            if ts[j - 1] == t and j - i == 1:
                out[i] = y
            else:
                _dense(ts[i:j], t_old, h, y_old, f_old, y, f, K, tab, drv, dy, F, out[i:j])
                nfev += 3
            i = j
        top = max(top, _top(y.view(np.complex128), d, N))
        if t - ts[-1] >= 0 and i < ts.size:
            return ys, top, -2
    return ys, top, nfev
