"""Tests of the brute-force Molmer-Sorensen oracle in tests/helpers/exact_ms.py.

Realistic parameters: xi0 = 5 kHz, eta = 0.026, eta*Omega = pi*xi0 (the
single-tone MS condition eta*Omega = delta/2).
"""

import numpy as np
import pytest
from scipy.integrate import quad

from tests.helpers.exact_ms import (
    S_OPERATOR,
    bell_fidelity,
    ideal_target,
    magnus_alpha_theta,
    magnus_prediction,
    motional_final_states,
    propagate_ms,
    thermal_weights,
)

XI0 = 5e3
ETA = 0.026
OMEGA = np.pi * XI0 / ETA
T_GATE = 1.0 / XI0
CARDIOID = dict(n=[1, 2], r=[1 / np.sqrt(1.5), -1 / np.sqrt(1.5)], phi=[0.0, 0.0])


def _random_tones(rng):
    """1-3 gate tones (|n| <= 3, signed) plus one resonant n = 0 tone."""
    k = int(rng.integers(1, 4))
    n = list(rng.choice([-3, -2, -1, 1, 2, 3], size=k, replace=False)) + [0]
    r = list(rng.uniform(-1, 1, size=k)) + [rng.uniform(0.02, 0.1) * rng.choice([-1, 1])]
    phi = list(rng.uniform(-np.pi, np.pi, size=k + 1))
    return np.array(n), np.array(r), np.array(phi)


# ----------------------------------------------------------------------------
# basic sanity
# ----------------------------------------------------------------------------
def test_thermal_weights_truncation():
    assert np.array_equal(thermal_weights(0.0), [1.0])
    for nbar in (0.1, 1.0):
        p = thermal_weights(nbar)
        q = nbar / (1 + nbar)
        m_max = p.size - 1
        assert q ** (m_max + 1) < 1e-12 <= q**m_max  # smallest such m_max
        assert abs(p.sum() - 1) < 1e-15
        exact = nbar**np.arange(p.size) / (1 + nbar) ** (np.arange(p.size) + 1)
        assert np.max(np.abs(p - exact)) < 1e-12


@pytest.mark.parametrize("nbar", [0.0, 0.1, 1.0])
def test_density_matrix_is_physical(nbar):
    n, r, phi = _random_tones(np.random.default_rng(7))
    rho = propagate_ms(n, r, phi, ETA, OMEGA, XI0, nbar)
    assert np.allclose(rho, rho.conj().T, atol=1e-14)
    assert abs(np.trace(rho) - 1) < 1e-11
    assert np.linalg.eigvalsh(rho).min() > -1e-11


# ----------------------------------------------------------------------------
# ideal gates
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("nbar", [0.0, 0.1, 1.0])
def test_single_tone_ms_gate_is_perfect_bell_state(nbar):
    rho, info = propagate_ms([1], [1.0], [0.0], ETA, OMEGA, XI0, nbar, return_info=True)
    # Sign convention found by the integration: |00> -> (|00> + i|11>)/sqrt2,
    # i.e. U = exp(+i pi/8 S^2) (theta = -pi/8 in exp(-i theta S^2)).
    bell = np.array([1, 0, 0, 1j]) / np.sqrt(2)
    assert 1 - bell_fidelity(rho, bell) < 1e-9
    assert bell_fidelity(rho, np.array([1, 0, 0, -1j]) / np.sqrt(2)) < 1e-9
    assert info["top_population"] < 1e-25
    target = ideal_target([1], [1.0], [0.0], ETA, OMEGA, XI0)
    assert abs(abs(np.vdot(target, bell)) - 1) < 1e-10
    assert 1 - bell_fidelity(rho, target) < 1e-9


def test_single_tone_is_exp_of_S_squared():
    """Brute-force U(T) restricted to spin equals exp(+i pi/8 S^2) on |00>."""
    w, v = np.linalg.eigh(S_OPERATOR)
    U = v @ np.diag(np.exp(1j * np.pi / 8 * w**2)) @ v.conj().T
    psi = U[:, 0]
    rho = propagate_ms([1], [1.0], [0.0], ETA, OMEGA, XI0, 0.0)
    assert np.max(np.abs(rho - np.outer(psi, psi.conj()))) < 1e-10
    alpha, theta = magnus_alpha_theta([1], [1.0], [0.0], ETA, OMEGA, XI0)
    assert abs(alpha) < 1e-12 and abs(theta + np.pi / 8) < 1e-12


@pytest.mark.parametrize("nbar", [0.0, 1.0])
def test_cardioid_1_2_gate(nbar):
    target = ideal_target(**CARDIOID, eta=ETA, Omega=OMEGA, xi0=XI0)
    assert abs(np.linalg.norm(target) - 1) < 1e-14
    rho = propagate_ms(**CARDIOID, eta=ETA, Omega=OMEGA, xi0=XI0, nbar=nbar)
    assert 1 - bell_fidelity(rho, target) < 1e-9
    # the loop closes and the accumulated phase is the MS value, so the target
    # is the same maximally entangled state as for the single tone
    bell = np.array([1, 0, 0, 1j]) / np.sqrt(2)
    assert abs(abs(np.vdot(target, bell)) - 1) < 1e-9
    alpha, theta = magnus_alpha_theta(**CARDIOID, eta=ETA, Omega=OMEGA, xi0=XI0)
    assert abs(alpha) < 1e-12 and abs(theta + np.pi / 8) < 1e-11


def test_bell_fidelity_and_open_loop_infidelity():
    """Off the gate time the loop is open: thermal motion must lower fidelity."""
    bell = np.array([1, 0, 0, 1j]) / np.sqrt(2)
    assert abs(bell_fidelity(np.outer(bell, bell.conj()), 3 * bell) - 1) < 1e-15
    T = 0.97 * T_GATE
    f0 = bell_fidelity(propagate_ms([1], [1.0], [0.0], ETA, OMEGA, XI0, 0.0, T=T), bell)
    f1 = bell_fidelity(propagate_ms([1], [1.0], [0.0], ETA, OMEGA, XI0, 1.0, T=T), bell)
    assert f1 < f0 < 1 - 1e-4


# ----------------------------------------------------------------------------
# brute force vs Magnus
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_brute_force_matches_magnus_on_random_tone_sets(seed):
    rng = np.random.default_rng(100 + seed)
    n, r, phi = _random_tones(rng)
    T = rng.uniform(0.7, 1.3) * T_GATE if seed % 2 else T_GATE
    worst = 0.0
    for nbar in (0.0, 0.1, 1.0, rng.uniform(0, 1)):
        rho = propagate_ms(n, r, phi, ETA, OMEGA, XI0, nbar, T=T)
        ref = magnus_prediction(n, r, phi, ETA, OMEGA, XI0, nbar, T=T)
        worst = max(worst, np.max(np.abs(rho - ref)))
    # measured ~1e-13 .. 6e-13
    assert worst < 1e-9


def test_blocks_match_full_joint_space_integration():
    """The S-block decomposition agrees with integrating the 4 x n_fock space."""
    n, r, phi = [1, 2, 0], [0.6, -0.5, 0.07], [0.3, -1.0, 0.5]
    for nbar in (0.0, 0.1):
        a = propagate_ms(n, r, phi, ETA, OMEGA, XI0, nbar, method="full")
        b = propagate_ms(n, r, phi, ETA, OMEGA, XI0, nbar, method="blocks")
        assert np.max(np.abs(a - b)) < 1e-10


@pytest.mark.parametrize("nbar", [0.0, 1.0])
def test_fock_cutoff_convergence(nbar):
    n, r, phi = [1, -2, 0], [0.8, 0.4, -0.1], [0.2, 1.1, -0.4]
    rho, info = propagate_ms(n, r, phi, ETA, OMEGA, XI0, nbar, return_info=True)
    assert info["top_population"] < 1e-25
    for extra in (10, 30):
        rho2 = propagate_ms(n, r, phi, ETA, OMEGA, XI0, nbar, n_fock=info["n_fock"] + extra)
        assert np.max(np.abs(rho - rho2)) < 1e-10
    if nbar == 0:
        # a deliberately too-small cutoff is detectably wrong (the check has teeth)
        rho_bad = propagate_ms(n, r, phi, ETA, OMEGA, XI0, nbar, n_fock=6)
        assert np.max(np.abs(rho - rho_bad)) > 1e-7


# ----------------------------------------------------------------------------
# resonant tone alone
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("phi0", [0.0, 0.7])
def test_resonant_tone_alone(phi0):
    """n = 0 only: f = (eta Omega/2) r0 e^{i phi0} is constant, so the block-s
    motion is the coherent state s*alpha with alpha = -i eta Omega r0 T e^{i phi0}/2
    (phi0 = 0: alpha = -i eta Omega r0 T / 2) and theta = 0."""
    r0, T = 0.05, 1.3 * T_GATE
    alpha_expected = -1j * ETA * OMEGA * r0 * T * np.exp(1j * phi0) / 2
    for s in (2, -2):
        psi = motional_final_states([0], [r0], [phi0], ETA, OMEGA, XI0, s=s, m_list=[0], T=T)[:, 0]
        a_psi = np.sqrt(np.arange(1, psi.size)) * psi[1:]
        mean_a = np.vdot(psi, np.append(a_psi, 0))  # <psi|a|psi>
        assert abs(mean_a / s - alpha_expected) < 1e-11
        assert abs(np.vdot(psi, psi) - 1) < 1e-12
    alpha, theta = magnus_alpha_theta([0], [r0], [phi0], ETA, OMEGA, XI0, T)
    assert abs(alpha - alpha_expected) < 1e-12 and abs(theta) < 1e-12
    for nbar in (0.0, 0.5):
        rho = propagate_ms([0], [r0], [phi0], ETA, OMEGA, XI0, nbar, T=T)
        ref = magnus_prediction([0], [r0], [phi0], ETA, OMEGA, XI0, nbar, T=T)
        assert np.max(np.abs(rho - ref)) < 1e-10


# ----------------------------------------------------------------------------
# relation to the paper's phase-space coordinates F, G, Phi
# ----------------------------------------------------------------------------
def _paper_FG(n, r, phi, t):
    """F(t), G(t) exactly as written in the paper (n = 0 terms via their limit)."""
    c = ETA * OMEGA / (2 * np.pi * XI0)
    F = G = 0.0
    for nn, rr, pp in zip(n, r, phi):
        if nn == 0:
            F += -np.sqrt(2) * ETA * OMEGA * rr * t * np.cos(pp)
            G += np.sqrt(2) * ETA * OMEGA * rr * t * np.sin(pp)
        else:
            F += -np.sqrt(2) * c * rr / nn * np.sin(2 * np.pi * nn * XI0 * t + pp)
            G += np.sqrt(2) * c * rr / nn * (np.cos(pp) - np.cos(2 * np.pi * nn * XI0 * t + pp))
    return F, G


def _paper_dG(n, r, phi, t):
    dG = 0.0
    for nn, rr, pp in zip(n, r, phi):
        if nn == 0:
            dG += np.sqrt(2) * ETA * OMEGA * rr * np.sin(pp)
        else:
            dG += np.sqrt(2) * ETA * OMEGA * rr * np.sin(2 * np.pi * nn * XI0 * t + pp)
    return dG


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_relation_to_paper_F_G_Phi(seed):
    """alpha' = 2 alpha (displacement per unit eigenvalue of S/2) satisfies
        alpha' = (G(T) + i [F(T) - F(0)]) / sqrt2,  |alpha'|^2 = (dF^2 + G^2)/2,
    and with Phi(T) = -int_0^T F dG
        theta = -(2 Phi + G(T) (F(T) + F(0))) / 8,
    i.e. for a closed loop U = D(alpha' S/2) exp(+i Phi (S/2)^2)."""
    rng = np.random.default_rng(200 + seed)
    n, r, phi = _random_tones(rng)
    T = rng.uniform(0.7, 1.3) * T_GATE
    alpha, theta = magnus_alpha_theta(n, r, phi, ETA, OMEGA, XI0, T)
    F_T, G_T = _paper_FG(n, r, phi, T)
    F_0, G_0 = _paper_FG(n, r, phi, 0.0)
    assert G_0 == 0.0
    alpha_p = 2 * alpha
    assert abs(alpha_p - (G_T + 1j * (F_T - F_0)) / np.sqrt(2)) < 1e-10
    assert abs(abs(alpha_p) ** 2 - ((F_T - F_0) ** 2 + G_T**2) / 2) < 1e-10
    # dG/dt formula cross-checked by finite differences
    h = 1e-9 * T
    fd = (_paper_FG(n, r, phi, 0.4 * T + h)[1] - _paper_FG(n, r, phi, 0.4 * T - h)[1]) / (2 * h)
    assert abs(fd - _paper_dG(n, r, phi, 0.4 * T)) < 1e-6 * abs(ETA * OMEGA)

    def scaled(u):  # F dG/dt dt with t = u T
        return _paper_FG(n, r, phi, u * T)[0] * _paper_dG(n, r, phi, u * T) * T

    Phi = -quad(scaled, 0, 1, epsabs=1e-13, limit=200)[0]
    assert abs(theta - (-(2 * Phi + G_T * (F_T + F_0)) / 8)) < 1e-10
    # and the brute-force displacement agrees with the paper coordinates too
    psi = motional_final_states(n, r, phi, ETA, OMEGA, XI0, s=2, m_list=[0], T=T)[:, 0]
    mean_a = np.vdot(psi[:-1], np.sqrt(np.arange(1, psi.size)) * psi[1:])
    assert abs(mean_a - alpha_p) < 1e-10  # block s = 2 is displaced by 2 alpha = alpha'


def test_closed_loop_phase_equals_paper_Phi():
    """Single tone and Cardioid(1,2) close at T: theta = -Phi/4 with Phi = pi/2."""
    for tones in (dict(n=[1], r=[1.0], phi=[0.0]), CARDIOID):
        alpha, theta = magnus_alpha_theta(**tones, eta=ETA, Omega=OMEGA, xi0=XI0)
        n, r, phi = tones["n"], tones["r"], tones["phi"]
        Phi = -quad(lambda u: _paper_FG(n, r, phi, u * T_GATE)[0]
                    * _paper_dG(n, r, phi, u * T_GATE) * T_GATE, 0, 1, epsabs=1e-13)[0]
        assert abs(Phi - np.pi / 2) < 1e-10
        assert abs(theta + Phi / 4) < 1e-10
