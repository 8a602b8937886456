"""Quantities of a spin state: analysis pulse, outcome and parity probabilities, Bell fidelities.

Measurements
------------
* Populations at time ``t``: ``P00, P01+P10, P11`` (two, one, zero bright
  ions; ``|0>`` bright).
* Parity analysis: after the gate an ideal, instantaneous global pi/2 pulse
  ``R(phi) = exp(-i pi/4 (cos phi X + sin phi Y))`` on each (good) ion, then
  measurement; ``P_even(phi) = P00 + P11``, ``Pi(phi) = 2 P_even - 1``.  For
  :data:`BELL_TARGET`, ``Pi(phi) = cos(2 phi + phi0)`` with ``phi0 = pi/2``,
  i.e. ``Pi = -sin(2 phi)``.  The contrast of a general state is
  ``2 |rho_{00,11}|``.  A branch with one ion out contributes terms at
  ``phi`` (not ``2 phi``), so fits should include them.
* Bell fidelities of the two-ion state after the gate (dephasing and
  heating included, preparation and detection not): ``fidelity`` w.r.t. the
  fixed :data:`BELL_TARGET` (ideal target of the ideal tone set; sensitive to
  the Bell-phase rotation caused by a common phase or a red/blue imbalance of
  the gate tones), ``fidelity_max`` (best Bell phase: what populations plus a
  free-phase parity fringe measure) and ``fidelity_gate`` (w.r.t. the state
  the setting's own gate tones produce without IM tones, errors or
  decoherence: :func:`gate_target`).
"""

from __future__ import annotations

import numpy as np

from .arguments import check_tones, positive
from .drive import calibrate_xi0
from .evolve import evolve

__all__ = ["BELL_TARGET", "analysis_rotation", "outcome_probabilities", "parity_outcomes",
           "collapse_outcomes", "state_bell_fidelity", "bell_fidelity_max", "gate_target"]

#: Ideal target of the symmetric real Cardioid(1,2) gate in this engine's convention.
BELL_TARGET = np.array([1.0, 0.0, 0.0, 1.0j]) / np.sqrt(2.0)


def analysis_rotation(phi):
    """``R(phi) = exp(-i pi/4 (cos phi X + sin phi Y))``, shape ``phi.shape + (2, 2)``."""
    phi = np.asarray(phi, dtype=float)
    s = 1 / np.sqrt(2)
    R = np.empty(phi.shape + (2, 2), dtype=complex)
    R[..., 0, 0] = s
    R[..., 1, 1] = s
    R[..., 0, 1] = -1j * s * np.exp(-1j * phi)
    R[..., 1, 0] = -1j * s * np.exp(1j * phi)
    return R


def outcome_probabilities(rho):
    """Diagonal of ``rho`` (real, clipped at 0): probabilities of ``00, 01, 10, 11`` or ``0, 1``."""
    rho = np.asarray(rho)
    return np.clip(np.real(np.diagonal(rho, axis1=-2, axis2=-1)), 0.0, None)


def parity_outcomes(rho, phases):
    """Outcome probabilities after the analysis pulse ``R(phi)`` on every ion.

    ``rho`` (4, 4) or (2, 2); returns shape ``(len(phases), 4)`` or ``(len(phases), 2)``.
    """
    rho = np.asarray(rho)
    R = analysis_rotation(np.atleast_1d(phases))
    if rho.shape[-1] == 4:
        R = np.einsum("kab,kcd->kacbd", R, R).reshape(-1, 4, 4)
    out = R @ rho @ np.conj(np.swapaxes(R, -1, -2))
    return outcome_probabilities(out)


def collapse_outcomes(p4):
    """(P00, P01+P10, P11) from four outcome probabilities."""
    p4 = np.asarray(p4)
    return np.stack([p4[..., 0], p4[..., 1] + p4[..., 2], p4[..., 3]], axis=-1)


def state_bell_fidelity(rho, target=None):
    """``<target|rho|target>``; default target :data:`BELL_TARGET` ``(|00> + i|11>)/sqrt2``.

    The fidelity of a simulated state (not the spectral estimate
    :func:`dpdfit.models.fidelity.bell_fidelity`).
    """
    t = BELL_TARGET if target is None else np.asarray(target, dtype=complex)
    t = t / np.linalg.norm(t)
    return float(np.real(np.conj(t) @ np.asarray(rho) @ t))


def bell_fidelity_max(rho):
    """Fidelity with the best ``(|00> + e^{i chi}|11>)/sqrt2``: ``(P00 + P11)/2 + |rho_{00,11}|``.

    This is what populations plus a parity fringe of free phase measure.
    """
    rho = np.asarray(rho)
    return float(0.5 * np.real(rho[0, 0] + rho[3, 3]) + abs(rho[0, 3]))


def gate_target(b, c, n, xi0, gate=(1, 2), n_fock=None, rtol=1e-10, atol=1e-12):
    """Target state of the setting's own gate tones (IM-free, perfectly calibrated).

    The spin state produced at ``T = 1/xi0`` from ``|00>`` at ``nbar = 0``,
    without decoherence, by the tones ``n in gate`` alone (with their actual
    complex red/blue amplitudes) at the ``eta Omega0`` that calibrates them to
    the given ``xi0`` (:func:`calibrate_xi0`).  Returned as the principal
    eigenvector of that (nearly pure) state, global phase fixed so that the
    ``|00>`` component is real positive.  The fidelity with it measures what
    the intermodulation tones, the power and rate errors and the decoherence
    do, not the frame (Bell phase) set by the common phase and red/blue
    imbalance of the gate tones; it is the analogue of the target used to
    validate :mod:`dpdfit.models.fidelity` against
    ``tests/helpers/exact_ms.py``.
    """
    b, c, n = check_tones(b, c, n)
    mask = np.isin(n, np.asarray(gate))
    eO = positive("xi0", xi0) / calibrate_xi0(b[mask], c[mask], n[mask], 1.0, gate)
    rho = evolve(b[mask], c[mask], n[mask], eO, xi0, 1.0 / xi0, 0.0, n_fock=n_fock,
                 rtol=rtol, atol=atol)
    w, v = np.linalg.eigh(rho)
    psi = v[:, -1]
    return psi * np.exp(-1j * np.angle(psi[0])) if abs(psi[0]) > 0 else psi
