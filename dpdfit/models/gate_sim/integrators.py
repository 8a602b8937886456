"""Integrators of the spin-motion dynamics: Schrodinger and Lindblad equations, DOP853 loop.

Numerics
--------
Dimensionless time ``tau = t xi0`` (the gate ends at ``tau = 1``); the state
lives in spin (x) truncated Fock space.  The Schrodinger equation
(:func:`integrate_schrodinger`) is integrated for all thermal Fock initial
states at once (columns of one matrix ODE), the Lindblad equation
(:func:`integrate_lindblad`) for the full density matrix (dimension
``(4 n_fock)^2``, ~ 1e4 complex numbers at ``nbar = 0.1``), both with
``scipy.integrate.DOP853`` stepped by hand (:func:`step_loop`); requested
times are read from each step's dense output and reduced to the spin density
matrix at once.  The master equation runs by default on the compiled kernel of
:mod:`~dpdfit.models.gate_sim.compiled_lindblad` (the same DOP853 steps on the same
right-hand side, states equal to rounding: ``tests/models/test_compiled_lindblad.py``);
``kernel="numpy"`` runs this module's numpy right-hand side under scipy's DOP853, the
reference.

* Integration error at the default tolerances (``rtol=1e-9, atol=1e-11``),
  against ``rtol=1e-11``: ~2e-12 in rho for the Schrodinger equation, ~4e-10
  for the master equation.
* Cost (2-core development machine, 8 tones per sideband, ``nbar = 0.1``,
  ``xi0 = 3.4 kHz``): :func:`dpdfit.models.gate_sim.evolve.evolve` ~50 ms
  (``n_fock = 27``), two-ion master equation ~0.21 s, one-ion ~0.03 s;
  ``nbar = 1`` ~1.2 s (the numpy reference; the compiled kernel takes less than
  half the CPU time).

Decoherence
-----------
* **Qubit dephasing** (coherence time ``T2`` [s], default 50 ms): Markovian
  ``sigma_z`` noise on each ion *during* the gate, Lindblad operators
  ``L_j = sqrt(1/(2 T2)) sigma_z^(j)``, so a single-ion coherence decays as
  ``exp(-t/T2)``.  Included exactly in the master equation.
* **Motional heating** (rate ``ndot`` [quanta/s], default 5 /s = 0.005
  quanta/ms): ``L_+ = sqrt(ndot) a^dag``, ``L_- = sqrt(ndot) a`` (heating
  towards infinite temperature, ``d<n>/dt = ndot``).  Exact in the master
  equation (the truncated dissipator stays trace preserving).

  Validation (tests): against first-order (Dyson) perturbation theory built
  from the analytic ``alpha(t)``, ``theta(t)`` of the ideal gate, in which a
  ``sigma_z`` jump at ``t`` acts as ``D(-2 alpha Y_j) exp(4 i theta Y_j Y_k) Z_j``
  and a heating jump as the spin-dependent kick ``a + alpha S_y``.  For the
  Cardioid(1,2) gate (``nbar = 0.1``) the first-order losses are: contrast
  ``T/T2``, Bell fidelity ``0.591 T/T2`` (0.581 at ``nbar = 0``; applying
  the dephasing channel at the end of the gate instead would give ``T/T2``,
  1.7x too much), heating ``4 ndot int_0^T |alpha|^2 dt = 3.7e-4`` at
  5 quanta/s and ``T = 294 us``.  The master equation agrees within the
  second-order remainder (``<= 2 (T/T2)^2``; measured ``0.29 (T/T2)^2 = 1e-5``
  at ``T2 = 50 ms``; heating ~ loss^2 = 1.4e-7).
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import DOP853

__all__ = ["step_loop", "integrate_schrodinger", "integrate_lindblad", "KERNELS",
           "load_compiled_kernel"]

#: the master equation's integrators: compiled (default) and the numpy reference
KERNELS = ("compiled", "numpy")


def step_loop(fun, y0, tau_out, rtol, atol, reduce, top_of):
    """Integrate with DOP853 and return ``[reduce(y(tau)) for tau in tau_out]``.

    ``top_of(y)`` is evaluated after every step; its maximum is returned too.
    """
    tau_out = np.asarray(tau_out, dtype=float)
    order = np.argsort(tau_out, kind="stable")
    ts = tau_out[order]
    out = [None] * ts.size
    i = 0
    top = top_of(y0)
    nfev = 0
    while i < ts.size and ts[i] <= 0.0:
        out[order[i]] = reduce(y0)
        i += 1
    if i < ts.size:
        solver = DOP853(fun, 0.0, y0, float(ts[-1]), rtol=rtol, atol=atol)
        while i < ts.size:
            msg = solver.step()
            if solver.status == "failed":
                raise RuntimeError(f"DOP853 failed: {msg}")
            j = i
            while j < ts.size and ts[j] <= solver.t:
                j += 1
            if j > i:
                if ts[j - 1] == solver.t and j - i == 1:
                    ys = solver.y[:, None]
                else:
                    ys = solver.dense_output()(ts[i:j])
                    if ys.ndim == 1:
                        ys = ys[:, None]
                for kk in range(j - i):
                    out[order[i + kk]] = reduce(ys[:, kk])
                i = j
            top = max(top, top_of(solver.y))
            if solver.status == "finished" and i < ts.size:
                raise RuntimeError("integration ended before the last requested time")
        nfev = solver.nfev
    return out, top, nfev


def integrate_schrodinger(drive, n_fock, p, tau_out, rtol, atol, init=0):
    """Spin density matrices at ``tau_out`` from ``|init> (x) sum_m p_m |m><m|``, no decoherence.

    Returns :func:`step_loop`'s ``(states, top-level population, RHS calls)``.
    """
    d = drive.dim
    M = p.size
    sq = np.sqrt(np.arange(1, n_fock))[None, :, None]
    shape = (d, n_fock, M)

    def rhs(tau, y):
        psi = y.reshape(shape)
        K = drive.K(tau)
        up = sq * psi[:, :-1]                    # a^dag psi, levels 1..N-1
        dn = sq * psi[:, 1:]                     # a psi,     levels 0..N-2
        out = np.zeros(shape, dtype=complex)
        out[:, 1:] = (K @ up.reshape(d, -1)).reshape(d, n_fock - 1, M)
        out[:, :-1] += (K.conj().T @ dn.reshape(d, -1)).reshape(d, n_fock - 1, M)
        return (-1j * out).ravel()

    psi0 = np.zeros(shape, dtype=complex)
    psi0[init, np.arange(M), np.arange(M)] = 1.0     # |spin init> (x) |m>
    sp = np.sqrt(p)

    def reduce(y):
        psi = y.reshape(shape) * sp
        return np.einsum("ikm,jkm->ij", psi, psi.conj())

    def top_of(y):
        psi = y.reshape(shape)
        return float(np.sum(p * np.sum(np.abs(psi[:, -1, :]) ** 2, axis=0)))

    return step_loop(rhs, psi0.ravel(), tau_out, rtol, atol, reduce, top_of)


def _dephasing_patterns(d, n_ions):
    """``(dist, corr)``: the factors of the independent and of the correlated dephasing
    rate in the dissipator's diagonal on ``rho_ij`` (``-gamma dist - gamma_c corr``)."""
    # Hamming distance between spin labels: (gamma/2) sum_j (z_j z_j' - 1) = -gamma * dist
    lab = np.arange(d)
    dist = np.zeros((d, d))
    zsum = np.zeros(d)
    for j in range(n_ions):
        bit = (lab >> j) & 1
        dist += bit[:, None] != bit[None, :]
        zsum += 1 - 2 * bit
    # correlated dephasing L = sqrt(gamma_c/2) sum_j Z_j: -(gamma_c/4) (S_i - S_j)^2 on rho_ij
    corr = 0.25 * (zsum[:, None] - zsum[None, :]) ** 2
    return dist, corr


def _dissipator_diagonal(d, n_ions, N, gamma, heat, gamma_c):
    """The dissipator's diagonal part (dephasing + heating anticommutator), real, on
    ``rho`` (d, N, d, N)."""
    dist, corr = _dephasing_patterns(d, n_ions)
    k = np.arange(N, dtype=float)
    v = k + np.where(k < N - 1, k + 1, 0.0)          # diag(a^dag a + a a^dag), truncated
    diag = ((-gamma * dist - gamma_c * corr)[:, None, :, None]
            - 0.5 * heat * (v[:, None] + v[None, :])[None, :, None, :])
    return np.ascontiguousarray(np.broadcast_to(diag, (d, N, d, N)))


def _dissipator(d, n_ions, N, gamma, heat, gamma_c):
    """Real coefficient arrays of the dissipator on the float view of ``rho`` (d, N, d, 2N).

    ``diag2``: the diagonal part (dephasing + heating anticommutator);
    ``sqsq2``: the coefficients of the heating jump terms ``a rho a^dag``, ``a^dag rho a``.
    """
    sq = np.sqrt(np.arange(1, N))
    # applied to the float view of rho (re/im interleaved on the last axis)
    diag2 = np.repeat(_dissipator_diagonal(d, n_ions, N, gamma, heat, gamma_c), 2, axis=-1)
    sqsq2 = np.repeat(heat * np.outer(sq, sq)[None, :, None, :], 2, axis=-1)
    return diag2, sqsq2


def integrate_lindblad(drive, n_fock, p, tau_out, gamma, heat, rtol, atol, init=0,
                       gamma_c=0.0, rates=None, kernel="compiled"):
    """Master equation; ``gamma = 1/(T2 xi0)``, ``heat = ndot/xi0``, ``gamma_c = 1/(T2c xi0)``
    (correlated dephasing) per unit tau; ``rates``: optional ``tau -> (gamma, gamma_c)`` of
    further, time-dependent dephasing (:func:`~dpdfit.models.gate_sim.dephasing.profile_rates`).
    Returns what :func:`step_loop` returns.

    ``kernel``: ``"compiled"`` (default) integrates with
    :mod:`~dpdfit.models.gate_sim.compiled_lindblad` (the same DOP853 steps, compiled: ~4x
    faster at the diagnosis's sizes); ``"numpy"`` with the numpy right-hand side and
    scipy's :class:`~scipy.integrate.DOP853`, the reference the compiled kernel is tested
    against.  A time-dependent ``rates`` is integrated by the reference.
    """
    if kernel not in KERNELS:
        raise ValueError(f"kernel must be one of {KERNELS}, got {kernel!r}")
    if kernel == "compiled" and rates is None:
        return _lindblad_compiled(drive, n_fock, p, tau_out, gamma, heat, rtol, atol, init,
                                  gamma_c)
    d = drive.dim
    N = n_fock
    DN = d * N
    sq_c = np.sqrt(np.arange(1, N))[None, :, None].astype(complex)
    diag2, sqsq2 = _dissipator(d, drive.n_ions, N, gamma, heat, gamma_c)
    if rates is not None:
        dist, corr = _dephasing_patterns(d, drive.n_ions)
        # on the float view of rho (re/im interleaved on the last axis), like diag2
        dist2 = np.repeat(np.broadcast_to((-dist)[:, None, :, None], (d, 1, d, N)), 2,
                          axis=-1)
        corr2 = np.repeat(np.broadcast_to((-corr)[:, None, :, None], (d, 1, d, N)), 2,
                          axis=-1)
    tmp = np.empty((d, N - 1, DN), dtype=complex)
    up = np.empty((d, N - 1, DN), dtype=complex)
    dn = np.empty((d, N - 1, DN), dtype=complex)
    dissipative = bool(gamma or heat or gamma_c)
    dbuf = np.empty_like(diag2)

    def rhs(tau, y):
        R = y.reshape(d, N, DN)
        mK, mKd = drive.minus_iK(tau)
        # A = -i H rho, H = K a^dag + K^dag a
        np.multiply(sq_c, R[:, :-1], out=tmp)
        np.matmul(mK, tmp.reshape(d, -1), out=up.reshape(d, -1))
        np.multiply(sq_c, R[:, 1:], out=tmp)
        np.matmul(mKd, tmp.reshape(d, -1), out=dn.reshape(d, -1))
        A = np.empty((d, N, DN), dtype=complex)
        A[:, 0] = dn[:, 0]
        np.add(up[:, :-1], dn[:, 1:], out=A[:, 1:-1])
        A[:, -1] = up[:, -1]
        A = A.reshape(DN, DN)
        out = np.empty((DN, DN), dtype=complex)
        np.conjugate(A.T, out=out)
        out += A                                         # -i [H, rho] = A + A^dag
        if dissipative:
            rf = y.view(np.float64).reshape(d, N, d, 2 * N)
            of = out.view(np.float64).reshape(d, N, d, 2 * N)
            np.multiply(diag2, rf, out=dbuf)
            of += dbuf
            if heat:
                of[:, :-1, :, :-2] += sqsq2 * rf[:, 1:, :, 2:]      # a rho a^dag
                of[:, 1:, :, 2:] += sqsq2 * rf[:, :-1, :, :-2]      # a^dag rho a
        if rates is not None:
            g, g_c = rates(tau)
            rf = y.view(np.float64).reshape(d, N, d, 2 * N)
            of = out.view(np.float64).reshape(d, N, d, 2 * N)
            of += (g * dist2 + g_c * corr2) * rf
        return out.ravel()

    rho0 = np.zeros((d, N, d, N), dtype=complex)
    m = np.arange(p.size)
    rho0[init, m, init, m] = p
    sidx = np.arange(d)

    def reduce(y):
        return np.einsum("ikjk->ij", y.reshape(d, N, d, N))

    def top_of(y):
        r4 = y.reshape(d, N, d, N)
        return float(np.real(np.sum(r4[sidx, N - 1, sidx, N - 1])))

    return step_loop(rhs, rho0.ravel(), tau_out, rtol, atol, reduce, top_of)


def _lindblad_compiled(drive, N, p, tau_out, gamma, heat, rtol, atol, init, gamma_c):
    """:func:`integrate_lindblad` by the compiled kernel: the same states, top-level
    population and right-hand-side count as the reference (to rounding)."""
    # numba is imported here, on the first integration, not with the package
    from .compiled_lindblad import TABLEAU, dop853_lindblad

    d = drive.dim
    diag = _dissipator_diagonal(d, drive.n_ions, N, gamma, heat, gamma_c).ravel()
    rho0 = np.zeros((d, N, d, N), dtype=complex)
    m = np.arange(p.size)
    rho0[init, m, init, m] = p
    y0 = rho0.ravel()
    tau_out = np.asarray(tau_out, dtype=float)
    order = np.argsort(tau_out, kind="stable")
    ts = tau_out[order]
    later = ts > 0.0
    sidx = np.arange(d)

    def reduce(y):
        return np.einsum("ikjk->ij", y.reshape(d, N, d, N))

    states = [reduce(y0)] * int(np.sum(~later))
    top = float(np.real(np.sum(rho0[sidx, N - 1, sidx, N - 1])))
    nfev = 0
    if later.any():
        b, cc, w, beta_at, gam_at = drive.coupling()
        ys, top, nfev = dop853_lindblad(y0, np.ascontiguousarray(ts[later]), float(rtol),
                                        float(atol), d, N, b, cc, w, beta_at, gam_at, diag,
                                        float(heat), TABLEAU)
        if nfev == -1:
            raise RuntimeError("DOP853 failed: the step size fell below the spacing of "
                               "the times")
        if nfev == -2:
            raise RuntimeError("integration ended before the last requested time")
        states += [reduce(y) for y in ys]
    out = [None] * ts.size
    for k, i in enumerate(order):
        out[i] = states[k]
    return out, top, nfev


def load_compiled_kernel() -> None:
    """Compile (or load from numba's disk cache) the compiled kernel now, in this process.

    A process that forks workers calls this first: the workers then inherit the machine
    code instead of each loading it again (~0.5 s a process, a pool per parallel map)."""
    from .drive import Drive

    drive = Drive(np.array([1.0 + 0j]), np.array([1.0 + 0j]), np.array([1]), 1.0, 1.0, 1)
    _lindblad_compiled(drive, 2, np.array([1.0]), np.array([0.5]), 0.1, 0.1, 1e-3, 1e-6, 0,
                       0.0)
