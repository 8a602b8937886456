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

#: scipy's DOP853 tableau (public class attributes), as contiguous arrays
TABLEAU = tuple(np.ascontiguousarray(x, dtype=float) for x in (
    DOP853.A, DOP853.B, DOP853.C, DOP853.E3, DOP853.E5, DOP853.D, DOP853.A_EXTRA,
    DOP853.C_EXTRA))

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
    # -i [H, rho] = A + A^dag, plus the dissipator
    for r in range(DN):
        k = r % N
        for s in range(DN):
            l = s % N
            v = A[r * DN + s] + np.conj(A[s * DN + r]) + diag[r * DN + s] * y[r * DN + s]
            if heat != 0.0:
                if k <= N - 2 and l <= N - 2:          # a rho a^dag
                    v += heat * sq[k + 1] * sq[l + 1] * y[(r + 1) * DN + s + 1]
                if k >= 1 and l >= 1:                  # a^dag rho a
                    v += heat * sq[k] * sq[l] * y[(r - 1) * DN + s - 1]
            out[r * DN + s] = v


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
def _combine(y, K, rows, coefs, h, out):
    """``out = y + h sum_r coefs[r] K[rows[r]]`` on the float view (the stage sums)."""
    m = y.size
    r0 = rows[0]
    a0 = coefs[0]
    for q in range(m):
        out[q] = a0 * K[r0, q]
    for r in range(1, rows.size):
        rr = rows[r]
        a = coefs[r]
        for q in range(m):
            out[q] += a * K[rr, q]
    for q in range(m):
        out[q] = y[q] + h * out[q]


@njit(cache=True)
def dop853_lindblad(y0, ts, rtol, atol, d, N, b, cc, w, beta_at, gam_at, diag, heat,
                    A_tab, B_tab, C_tab, E3, E5, D_tab, A_ext, C_ext):
    """States at the increasing times ``ts`` (all > 0) from ``y0`` at 0, the largest
    top-level population after any step, and the right-hand sides evaluated:
    ``(ys (len(ts), n), top, nfev)``; ``nfev = -1``: the step size fell below its
    minimum (scipy's "too small step"); ``-2``: the last time was not reached.

    The Runge-Kutta sums run on the states' float views (real coefficients)."""
    n = y0.size
    m = 2 * n
    sq = np.sqrt(np.arange(N).astype(np.float64))
    scratch = np.empty(n, dtype=np.complex128)
    n_stages = B_tab.size
    n_ext = n_stages + 4
    # the nonzero coefficients of every stage sum: rows (n_ext + 1, n_ext), counts
    tab_rows = np.zeros((n_ext + 1, n_ext), dtype=np.int64)
    tab_coef = np.zeros((n_ext + 1, n_ext))
    tab_cnt = np.zeros(n_ext + 1, dtype=np.int64)
    for s in range(1, n_ext):
        for r in range(s):
            a = A_tab[s, r] if s < n_stages else (B_tab[r] if s == n_stages
                                                   else A_ext[s - n_stages - 1, r])
            if s == n_stages and r >= n_stages:
                a = 0.0
            if a != 0.0:
                tab_rows[s, tab_cnt[s]] = r
                tab_coef[s, tab_cnt[s]] = a
                tab_cnt[s] += 1
    K = np.empty((n_ext, m))
    ys = np.empty((ts.size, n), dtype=np.complex128)
    t_bound = ts[-1]
    y = y0.copy().view(np.float64)
    f = np.empty(m)
    lindblad_rhs(0.0, y.view(np.complex128), f.view(np.complex128), d, N, b, cc, w,
                 beta_at, gam_at, diag, heat, sq, scratch)
    nfev = 1
    # scipy's select_initial_step (error estimator order 7)
    yc = y.view(np.complex128)
    fc = f.view(np.complex128)
    scale = atol + np.abs(yc) * rtol
    d0 = _rms(yc / scale)
    d1 = _rms(fc / scale)
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    h0 = min(h0, t_bound)
    f1 = np.empty(n, dtype=np.complex128)
    lindblad_rhs(h0, yc + h0 * fc, f1, d, N, b, cc, w, beta_at, gam_at, diag, heat, sq,
                 scratch)
    nfev += 1
    d2 = _rms((f1 - fc) / scale) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    h_abs = min(100 * h0, h1, t_bound)
    top = _top(yc, d, N)
    t = 0.0
    i = 0
    dy = np.empty(m)
    y_new = np.empty(m)
    y_old = np.empty(m)
    f_old = np.empty(m)
    F = np.empty((7, m))
    while i < ts.size:
        min_step = 10 * abs(np.nextafter(t, np.inf) - t)
        if h_abs < min_step:
            h_abs = min_step
        accepted = False
        rejected = False
        h = 0.0
        t_new = t
        while not accepted:
            if h_abs < min_step:
                return ys, top, -1
            h = h_abs
            t_new = t + h
            if t_new - t_bound > 0:
                t_new = t_bound
            h = t_new - t
            h_abs = abs(h)
            # scipy's rk_step
            K[0, :] = f
            for s in range(1, n_stages):
                c = tab_cnt[s]
                _combine(y, K, tab_rows[s, :c], tab_coef[s, :c], h, dy)
                lindblad_rhs(t + C_tab[s] * h, dy.view(np.complex128),
                             K[s].view(np.complex128), d, N, b, cc, w, beta_at, gam_at,
                             diag, heat, sq, scratch)
            c = tab_cnt[n_stages]
            _combine(y, K, tab_rows[n_stages, :c], tab_coef[n_stages, :c], h, y_new)
            lindblad_rhs(t + h, y_new.view(np.complex128), K[n_stages].view(np.complex128),
                         d, N, b, cc, w, beta_at, gam_at, diag, heat, sq, scratch)
            nfev += n_stages
            # scipy's DOP853._estimate_error_norm
            e5 = 0.0
            e3 = 0.0
            for q in range(n):
                ya = math.hypot(y[2 * q], y[2 * q + 1])
                yb = math.hypot(y_new[2 * q], y_new[2 * q + 1])
                sc = atol + max(ya, yb) * rtol
                x5r = 0.0
                x5i = 0.0
                x3r = 0.0
                x3i = 0.0
                for r in range(n_stages + 1):
                    kr = K[r, 2 * q]
                    ki = K[r, 2 * q + 1]
                    x5r += kr * E5[r]
                    x5i += ki * E5[r]
                    x3r += kr * E3[r]
                    x3i += ki * E3[r]
                e5 += (x5r * x5r + x5i * x5i) / (sc * sc)
                e3 += (x3r * x3r + x3i * x3i) / (sc * sc)
            if e5 == 0.0 and e3 == 0.0:
                err = 0.0
            else:
                err = abs(h) * e5 / math.sqrt((e5 + 0.01 * e3) * n)
            if err < 1:
                if err == 0:
                    factor = _MAX_FACTOR
                else:
                    factor = min(_MAX_FACTOR, _SAFETY * err ** _ERROR_EXPONENT)
                if rejected:
                    factor = min(1.0, factor)
                h_abs *= factor
                accepted = True
            else:
                h_abs *= max(_MIN_FACTOR, _SAFETY * err ** _ERROR_EXPONENT)
                rejected = True
        t_old = t
        y_old[:] = y
        f_old[:] = f
        t = t_new
        y[:] = y_new
        f[:] = K[n_stages]
        finished = t - t_bound >= 0
        j = i
        while j < ts.size and ts[j] <= t:
            j += 1
        if j > i:
            if ts[j - 1] == t and j - i == 1:
                ys[i] = y.view(np.complex128)
            else:
                # scipy's DOP853 dense output: three more stages, a degree-7 interpolant
                for s in range(n_stages + 1, n_ext):
                    c = tab_cnt[s]
                    _combine(y_old, K, tab_rows[s, :c], tab_coef[s, :c], h, dy)
                    lindblad_rhs(t_old + C_ext[s - n_stages - 1] * h, dy.view(np.complex128),
                                 K[s].view(np.complex128), d, N, b, cc, w, beta_at, gam_at,
                                 diag, heat, sq, scratch)
                nfev += 3
                for q in range(m):
                    delta = y[q] - y_old[q]
                    F[0, q] = delta
                    F[1, q] = h * f_old[q] - delta
                    F[2, q] = 2 * delta - h * (f[q] + f_old[q])
                for p in range(4):
                    for q in range(m):
                        F[3 + p, q] = 0.0
                    for r in range(n_ext):
                        a = D_tab[p, r]
                        if a != 0.0:
                            for q in range(m):
                                F[3 + p, q] += a * K[r, q]
                    for q in range(m):
                        F[3 + p, q] *= h
                out = ys.view(np.float64)
                for jj in range(i, j):
                    x = (ts[jj] - t_old) / h
                    for q in range(m):
                        v = 0.0
                        for k7 in range(7):
                            v += F[6 - k7, q]
                            if k7 % 2 == 0:
                                v *= x
                            else:
                                v *= 1 - x
                        out[jj, q] = v + y_old[q]
            i = j
        top = max(top, _top(y.view(np.complex128), d, N))
        if finished and i < ts.size:
            return ys, top, -2
    return ys, top, nfev
