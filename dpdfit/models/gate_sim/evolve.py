"""Reduced spin states after the gate drive: :func:`evolve` (Schrodinger), :func:`evolve_lindblad`.

The Fock dimension is chosen by the rule of :mod:`dpdfit.models.gate_sim.fock`
and checked along the way: the population of the top level is monitored over
the whole integration; if it exceeds 1e-12 (possible for strongly
non-commuting drives, where ``B`` is only the first-order displacement)
``n_fock`` is enlarged and the run repeated.  The tests check that
``n_fock + 10`` changes the result by < 1e-11.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from dpdfit.errors import InputError

from .arguments import check_times, check_tones, positive
from .dephasing import profile_rates
from .drive import Drive
from .fock import thermal_weights
from .integrators import integrate_lindblad, integrate_schrodinger
from .size import check_engine_size, engine_size

__all__ = ["evolve", "evolve_lindblad"]

_MONITOR_TOL = 1e-12     # top-level population allowed along the integration


def _integrate(kind, drive, size, auto, p, tau, rtol, atol, initial, gamma, heat, gamma_c,
               monitor=_MONITOR_TOL, rates=None, kernel="compiled"):
    """Integrate, enlarging an automatic ``n_fock`` until the top level stays empty (each
    size checked against the memory limit first)."""
    N = size.n_fock
    for _ in range(6):
        check_engine_size(dataclasses.replace(size, n_fock=N))
        if kind == "pure":
            out, top, nfev = integrate_schrodinger(drive, N, p, tau, rtol, atol, initial)
        else:
            out, top, nfev = integrate_lindblad(drive, N, p, tau, gamma, heat, rtol, atol,
                                                initial, gamma_c, rates, kernel)
        if not auto or top < monitor:
            return out, top, nfev, N
        N = int(math.ceil(1.3 * N)) + 4
    raise RuntimeError(f"Fock cutoff did not converge (top-level population {top:g} "
                       f"at n_fock={N})")


def _run(kind, b, c, n, eta_Omega0, xi0, times, nbar, n_fock, rtol, atol, n_ions,
         gamma=0.0, heat=0.0, initial=0, gamma_c=0.0, fock_tol=None, rates=None,
         kernel="compiled"):
    b, c, n = check_tones(b, c, n)
    eta_Omega0 = positive("eta_Omega0", eta_Omega0, allow_zero=True)
    xi0 = positive("xi0", xi0)
    if n_ions not in (1, 2):
        raise InputError(f"n_ions must be 1 or 2, got {n_ions}")
    if int(initial) != initial or not 0 <= initial < 2 ** n_ions:
        raise InputError(f"initial spin state must be 0..{2 ** n_ions - 1}, got {initial}")
    t = check_times(times)
    scalar = t.ndim == 0
    t1 = np.atleast_1d(t)
    # fock_tol: the population neglected in the thermal tail, above the cutoff and at
    # the top level along the way (default: the engine's 1e-10 / 1e-14 / 1e-12)
    size = engine_size(b, c, n, eta_Omega0, xi0, float(t1.max()) if t1.size else 0.0, nbar,
                       n_ions=n_ions, lindblad=kind != "pure", n_fock=n_fock, fock_tol=fock_tol)
    N, B = size.n_fock, size.B
    if N < size.n_thermal + 1:
        raise InputError(f"n_fock={N} too small for the thermal sum "
                         f"(m_max={size.n_thermal - 1})")
    check_engine_size(size)          # before the thermal weights and the state are made
    p = thermal_weights(nbar) if fock_tol is None else thermal_weights(nbar, fock_tol)
    drive = Drive(b, c, n, eta_Omega0, xi0, n_ions)
    out, top, nfev, N = _integrate(kind, drive, size, n_fock is None, p, t1 * xi0, rtol, atol,
                                   int(initial), gamma, heat, gamma_c,
                                   _MONITOR_TOL if fock_tol is None else 10 * fock_tol, rates,
                                   kernel)
    rho = np.array(out).reshape((t1.size, drive.dim, drive.dim)) if out else \
        np.zeros((0, drive.dim, drive.dim), dtype=complex)
    rho = 0.5 * (rho + np.conj(np.swapaxes(rho, -1, -2)))
    info = {"n_fock": N, "m_max": p.size - 1, "B": B, "top_population": top, "nfev": nfev}
    return (rho[0] if scalar else rho), info


def evolve(b, c, n, eta_Omega0, xi0, times, nbar, n_fock=None, rtol=1e-9, atol=1e-11,
           *, n_ions=2, initial=0, return_info=False, fock_tol=None):
    """Reduced spin density matrices by brute-force Schrodinger integration.

    Starts from ``|0...0> (x) rho_thermal(nbar)``; every thermal Fock state is
    a column of one matrix ODE in spin (x) truncated Fock space, integrated in
    ``tau = t xi0`` with DOP853.  No decoherence (see :func:`evolve_lindblad`).

    Parameters
    ----------
    b, c : array_like of complex, shape (T,)
        Blue / red tone amplitudes ``E_k`` (:mod:`dpdfit.models.gate_sim.drive`;
        normalised field units).
    n : array_like of int, shape (T,)
        Harmonic indices (any integers, distinct).
    eta_Omega0 : float
        ``eta * Omega0`` [rad/s].
    xi0 : float
        Tone spacing [Hz]: tone ``n`` is detuned by ``n xi0`` from the sideband.
    times : float or array_like
        Times [s] (any order; 0 allowed).
    nbar : float
        Initial mean phonon number of the thermal mode.
    n_fock : int, optional
        Fock dimension; automatic by default (module docstring).
    rtol, atol : float
        DOP853 tolerances (amplitudes are O(1)).
    n_ions : {2, 1}
        Two ions (4x4 result) or one ion alone (2x2; the prep-error branch).
    initial : int
        Initial spin basis state (index into ``|00>, |01>, |10>, |11>``, or
        ``|0>, |1>`` for one ion); default ``|0...0>``.
    return_info : bool
        Also return ``{"n_fock", "m_max", "B", "top_population", "nfev"}``.
    fock_tol : float, optional
        Population neglected in the thermal tail and above the Fock cutoff (default:
        the engine's 1e-10 and 1e-14).

    Returns
    -------
    rho : ndarray of complex, shape (..., 4, 4)
        Basis ``|00>, |01>, |10>, |11>`` (``(..., 2, 2)`` for one ion), one per time.
    """
    rho, info = _run("pure", b, c, n, eta_Omega0, xi0, times, nbar, n_fock, rtol, atol, n_ions,
                     initial=initial, fock_tol=fock_tol)
    return (rho, info) if return_info else rho


def evolve_lindblad(b, c, n, eta_Omega0, xi0, times, nbar, *, T2=np.inf, ndot=0.0,
                    n_fock=None, rtol=1e-9, atol=1e-11, n_ions=2, initial=0,
                    T2_corr=np.inf, return_info=False, fock_tol=None,
                    dephasing_profile=None, kernel="compiled"):
    """Reduced spin density matrices from the Lindblad master equation.

    Same model and arguments as :func:`evolve`, plus ::

        d rho/dt = -i [H, rho] + (1/(2 T2)) sum_j (Z_j rho Z_j - rho)
                   + ndot (a rho a^dag + a^dag rho a - {a^dag a + a a^dag, rho}/2).

    Parameters
    ----------
    T2 : float
        Qubit coherence time [s] (``inf``: no dephasing).
    ndot : float
        Heating rate [quanta/s].
    T2_corr : float
        Coherence time [s] of *correlated* (common-mode) dephasing, Lindblad
        operator ``sqrt(1/(2 T2_corr)) (Z_1 + Z_2)``: each single-ion coherence
        decays as ``exp(-t/T2_corr)`` as for ``T2``, but ``|00><11|`` four times as
        fast (twice as fast as with independent noise), ``|01><10|`` not at all.
    fock_tol : float, optional
        Population neglected in the thermal tail and above the Fock cutoff (default:
        the engine's 1e-10 and 1e-14); the diagnosis uses 1e-8, far below shot noise.
    dephasing_profile : tuple, optional
        ``(rate, rate_common, beta, t_ref)``: further dephasing, independent on each ion
        and common to both, that accumulates ``G(t) = rate t_ref (t/t_ref)^beta`` (slow
        noise), as a time-local rate (:mod:`dpdfit.models.gate_sim.dephasing`).
    kernel : {"compiled", "numpy"}
        The integrator (:func:`~dpdfit.models.gate_sim.integrators.integrate_lindblad`):
        compiled (default), or the numpy reference it is tested against; the same
        DOP853 steps, states equal to rounding.
    """
    T2 = positive("T2", T2, allow_inf=True)
    T2_corr = positive("T2_corr", T2_corr, allow_inf=True)
    ndot = positive("ndot", ndot, allow_zero=True)
    xi0f = positive("xi0", xi0)
    gamma = 0.0 if np.isinf(T2) else 1.0 / (T2 * xi0f)
    gamma_c = 0.0 if np.isinf(T2_corr) else 1.0 / (T2_corr * xi0f)
    rates = None if dephasing_profile is None else profile_rates(dephasing_profile, xi0f)
    rho, info = _run("lindblad", b, c, n, eta_Omega0, xi0, times, nbar, n_fock, rtol, atol,
                     n_ions, gamma=gamma, heat=ndot / xi0f, initial=initial, gamma_c=gamma_c,
                     fock_tol=fock_tol, rates=rates, kernel=kernel)
    return (rho, info) if return_info else rho
