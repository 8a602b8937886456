"""Measured probabilities of one gate setting, with all imperfections (the engine's main entry).

Cost (2-core development machine, 8 tones per sideband, ``nbar = 0.1``,
``xi0 = 3.4 kHz``): :func:`simulate_setting` with the defaults ~0.25 s
(+0.08 s for a 41-point time scan).
"""

from __future__ import annotations

import functools
import time

import numpy as np

from dpdfit.core.defaults import ERROR_MODEL, NBAR
from dpdfit.errors import InputError

from .arguments import check_times, positive
from .evolve import evolve, evolve_lindblad
from .results import SettingProbabilities
from .spam import (branch_states, confusion, detection_errors, mixed_outcomes,
                   prep_probabilities)
from .states import (bell_fidelity_max, collapse_outcomes, gate_target, outcome_probabilities,
                     parity_outcomes, state_bell_fidelity)

__all__ = ["T2_S", "NDOT", "P_PREP", "P_DET", "populations", "parity_even", "setting_branches",
           "simulate_setting"]

# The lab's error model (dpdfit.core.defaults.ERROR_MODEL, sources there): the defaults
# of every function of this module.
#: Qubit coherence time [s].
T2_S = ERROR_MODEL.T2_s
#: Motional heating rate [quanta/s].
NDOT = ERROR_MODEL.heating_quanta_per_s
#: Per-ion state-preparation error (spectator probability).
P_PREP = ERROR_MODEL.p_prep
#: Per-ion detection error.
P_DET = ERROR_MODEL.p_det


def _analysis_phases(phases):
    """Analysis phases [rad]; default ``2 pi k/16``, ``k = 0..15`` (``ERROR_MODEL``'s 16)."""
    return (ERROR_MODEL.analysis_phases() if phases is None
            else np.atleast_1d(np.asarray(phases, dtype=float)))


def populations(b, c, n, eta_Omega0, xi0, times=None, *, nbar=NBAR, T2=T2_S, ndot=NDOT,
                p_prep=P_PREP, p_det=P_DET, p_flip=0.0, n_fock=None, rtol=1e-9, atol=1e-11):
    """Measured populations ``(P00, P01+P10, P11)`` with all imperfections.

    ``times`` [s] defaults to the gate time ``1/xi0``; returns shape
    ``times.shape + (3,)``.  Other arguments as in :func:`simulate_setting`.
    """
    p_prep, p_flip = prep_probabilities(p_prep, p_flip)
    p_det = detection_errors(p_det)
    times = 1.0 / xi0 if times is None else times
    t = np.asarray(times, dtype=float)
    rho2, rho1, _, flips = branch_states(b, c, n, eta_Omega0, xi0, t, nbar, T2, ndot, p_prep,
                                         n_fock, rtol, atol, p_flip)
    p4 = mixed_outcomes(rho2, rho1, flips, p_prep, p_flip, outcome_probabilities)
    return collapse_outcomes(confusion(p4, p_det))


def parity_even(b, c, n, eta_Omega0, xi0, phases=None, *, nbar=NBAR, T2=T2_S, ndot=NDOT,
                p_prep=P_PREP, p_det=P_DET, p_flip=0.0, n_fock=None, rtol=1e-9, atol=1e-11):
    """``P_even(phi)`` after gate (``T = 1/xi0``) + analysis pulse, all imperfections."""
    p_prep, p_flip = prep_probabilities(p_prep, p_flip)
    p_det = detection_errors(p_det)
    phases = _analysis_phases(phases)
    rho2, rho1, _, flips = branch_states(b, c, n, eta_Omega0, xi0, 1.0 / xi0, nbar, T2, ndot,
                                         p_prep, n_fock, rtol, atol, p_flip)
    p4 = mixed_outcomes(rho2, rho1, flips, p_prep, p_flip,
                        functools.partial(parity_outcomes, phases=phases))
    p4 = confusion(p4, p_det)
    return p4[..., 0] + p4[..., 3]


def setting_branches(b, c, n, eta_Omega0, xi0, *, nbar=NBAR, T2=T2_S, ndot=NDOT,
                     phases=None, scan_times=None, power_error_db=0.0, spectator=True,
                     flip=True, n_fock=None, rtol=1e-9, atol=1e-11, T2_corr=np.inf,
                     fock_tol=None, branches=None) -> dict:
    """Raw outcome probabilities of the preparation branches of one setting.

    No preparation mixing and no detection error: what
    :func:`~dpdfit.models.gate_sim.spam.mix_branches` and
    :func:`~dpdfit.models.gate_sim.spam.confusion` turn into measured
    probabilities for *any* ``p_prep``, ``p_flip`` and detection errors,
    exactly and without another integration (the diagnosis fits those as
    nuisances).

    Returns
    -------
    dict
        ``p2`` (1 + S, 4): two ions from ``|00>`` at the gate time then the scan
        times; ``par2`` (K, 4): after the analysis pulse at ``phases``;
        with ``spectator``: ``p1``, ``par1`` (one driven ion from ``|0>``);
        with ``flip``: ``p2_01``, ``par2_01`` (two ions from ``|01>``); with
        both: ``p1_1``, ``par1_1`` (one driven ion from ``|1>``); and
        ``phases``, ``times``.  ``branches``: only those of ``("2", "1", "2_01",
        "1_1")`` named (each branch is its own integration, so a caller may run them
        apart, e.g. in parallel, and join the dicts).
    """
    T2 = positive("T2", T2, allow_inf=True)
    ndot = positive("ndot", ndot, allow_zero=True)
    eO = positive("eta_Omega0", eta_Omega0) * 10 ** (float(power_error_db) / 20)
    phases = _analysis_phases(phases)
    T = 1.0 / positive("xi0", xi0)
    scan = np.zeros(0) if scan_times is None else np.atleast_1d(check_times(scan_times))
    times = np.concatenate([[T], scan])
    lind = not (np.isinf(T2) and ndot == 0 and np.isinf(T2_corr))
    f = (functools.partial(evolve_lindblad, T2=T2, ndot=ndot, T2_corr=T2_corr) if lind
         else evolve)
    kw = dict(n_fock=n_fock, rtol=rtol, atol=atol, fock_tol=fock_tol)
    out = {"phases": phases, "times": times}
    runs = [("2", 2, 0)] + ([("1", 1, 0)] if spectator else []) + (
        [("2_01", 2, 1)] if flip else []) + ([("1_1", 1, 1)] if spectator and flip else [])
    if branches is not None:
        unknown = set(branches) - {"2", "1", "2_01", "1_1"}
        if unknown:
            raise InputError(f"unknown branches {sorted(unknown)}; known: 2, 1, 2_01, 1_1")
        runs = [r for r in (("2", 2, 0), ("1", 1, 0), ("2_01", 2, 1), ("1_1", 1, 1))
                if r[0] in branches]
    for name, ions, init in runs:
        rho = f(b, c, n, eO, xi0, times, nbar, n_ions=ions, initial=init, **kw)
        out["p" + name] = outcome_probabilities(rho)
        out["par" + name] = parity_outcomes(rho[0], phases)
    return out


def _measured(rho2, rho1, flips, p_prep, p_flip, p_det, phases):
    """Measured ``(P00, P01+P10, P11)``: at every time, and after the analysis pulse at
    ``phases`` at the first time (the gate time)."""
    pops = collapse_outcomes(confusion(mixed_outcomes(rho2, rho1, flips, p_prep, p_flip,
                                                      outcome_probabilities), p_det))
    first = None if flips is None else tuple(None if r is None else r[0] for r in flips)
    par = mixed_outcomes(rho2[0], None if rho1 is None else rho1[0], first, p_prep, p_flip,
                         functools.partial(parity_outcomes, phases=phases))
    return pops, collapse_outcomes(confusion(par, p_det))


def _with_power_error(eta_Omega0, power_error_db) -> float:
    """``eta Omega0`` at gate time: with the laser-power error ``power_error_db`` (dB)."""
    if not np.isfinite(power_error_db):
        raise InputError(f"power_error_db must be finite, got {power_error_db}")
    return positive("eta_Omega0", eta_Omega0) * 10 ** (float(power_error_db) / 20)


def simulate_setting(b, c, n, eta_Omega0, xi0, *, nbar=NBAR, T2=T2_S, ndot=NDOT,
                     p_prep=P_PREP, p_det=P_DET, parity_phases=None, scan_times=None,
                     power_error_db=0.0, n_fock=None, rtol=1e-9, atol=1e-11,
                     target=None, gate=(1, 2), p_flip=0.0, T2_corr=np.inf,
                     dephasing_profile=None, coherence=None) -> SettingProbabilities:
    """Outcome probabilities of one gate setting.

    The gate runs for ``T = 1/xi0`` with tones at ``n xi0`` from the sidebands;
    the dynamics use ``eta_Omega0 * 10**(power_error_db/20)`` (a laser-power
    error at gate time, with ``xi0`` kept as calibrated).  Dephasing and
    heating act during the gate (master equation); preparation and detection
    errors as described in :mod:`dpdfit.models.gate_sim.spam`.

    Parameters
    ----------
    b, c, n : array_like
        Blue / red tone amplitudes (normalised field units, engine convention:
        see :func:`~dpdfit.models.gate_sim.drive.field_amplitudes`) and harmonic indices.
    eta_Omega0 : float
        ``eta * Omega0`` [rad/s].
    xi0 : float
        Tone spacing [Hz] (typically from :func:`~dpdfit.models.gate_sim.drive.calibrate_xi0`).
    nbar : float
        Mean thermal phonon number at the start of the gate.
    T2, T2_corr : float
        Coherence times [s] of each qubit's own and of common (both ions) dephasing
        (``np.inf``: none; :func:`~dpdfit.models.gate_sim.evolve.evolve_lindblad`).
    ndot : float
        Heating rate [quanta/s].
    p_prep : float
        Per-ion probability of a spectator (pumped out of the qubit; not driven,
        reads bright).
    p_det : float or (float, float)
        Per-ion detection error: one probability (symmetric) or ``(e01, e10)``
        (bright read dark, dark read bright).
    p_flip : float
        Per-ion probability of starting in the wrong qubit state ``|1>`` (driven).
    parity_phases : array_like, optional
        Analysis phases [rad]; default ``2 pi k/16``, ``k = 0..15``.
    scan_times : array_like, optional
        Gate durations [s] of a time scan (populations only).
    power_error_db : float
        Optical power error [dB] at gate time.
    target : array_like, optional
        Target state for ``fidelity`` (default :data:`~dpdfit.models.gate_sim.states.BELL_TARGET`).
    gate : tuple of int
        Gate harmonics (for ``fidelity_gate``).
    dephasing_profile, coherence : tuple, optional
        Slow dephasing during and after the gate (:mod:`dpdfit.models.gate_sim.dephasing`).

    Returns
    -------
    SettingProbabilities
    """
    t0 = time.perf_counter()
    xi0 = positive("xi0", xi0)
    T2 = positive("T2", T2, allow_inf=True)
    ndot = positive("ndot", ndot, allow_zero=True)
    p_prep, p_flip = prep_probabilities(p_prep, p_flip)
    p_det = detection_errors(p_det)
    eO = _with_power_error(eta_Omega0, power_error_db)
    phases = _analysis_phases(parity_phases)
    T = 1.0 / xi0
    scan = None if scan_times is None else np.atleast_1d(check_times(scan_times))
    times = np.concatenate([[T], scan]) if scan is not None else np.array([T])
    rho2, rho1, info, flips = branch_states(b, c, n, eO, xi0, times, nbar, T2, ndot, p_prep,
                                            n_fock, rtol, atol, p_flip, T2_corr,
                                            dephasing_profile, coherence)
    pops, par = _measured(rho2, rho1, flips, p_prep, p_flip, p_det, phases)
    info["seconds"] = time.perf_counter() - t0
    return SettingProbabilities(
        xi0=xi0, T_gate=T, eta_Omega0=eO, pop=pops[0], parity_phases=phases,
        parity_probs=par, rho_gate=rho2[0], fidelity=state_bell_fidelity(rho2[0], target),
        fidelity_max=bell_fidelity_max(rho2[0]),
        fidelity_gate=state_bell_fidelity(rho2[0], gate_target(b, c, n, xi0, gate)),
        scan_times=scan, scan_pop=None if scan is None else pops[1:],
        params={"nbar": float(nbar), "T2": T2, "ndot": ndot, "p_prep": p_prep, "p_det": p_det,
                "p_flip": p_flip, "power_error_db": float(power_error_db),
                "eta_Omega0_calibrated": float(eta_Omega0)},
        info=info)
