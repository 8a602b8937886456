"""Slow dephasing in the gate engine (dpdfit.models.gate_sim.dephasing): a time profile of
the dephasing during the gate, and a decay of the final state's coherences.

References are independent of the code under test: the engine's own constant-rate
Lindblad dephasing (a profile with beta = 1 is that), a quadrature of the time-local rate
against G(t), the average of the state over Gaussian phase noise (Gauss-Hermite), and the
limit of a profile concentrated at the end of the gate (the final-state decay)."""

import numpy as np
import pytest

from dpdfit.errors import InputError
from dpdfit.models import gate_sim as gs
from dpdfit.models.gate_sim.dephasing import (T_FLOOR, accumulated_dephasing,
                                              dephase_coherences, profile_rates)

XI0 = 3.4e3
T = 1 / XI0
S = 1 / np.sqrt(1.5)
N_C = np.array([1, 2])
R_C = np.array([S, -S])
EO = XI0 / gs.calibrate_xi0(R_C, R_C, N_C, 1.0)
TIMES = np.linspace(0, T, 4)


def test_a_profile_with_beta_one_is_the_constant_rate():
    const = gs.evolve_lindblad(R_C, R_C, N_C, EO, XI0, TIMES, 0.1, T2=1 / (20 + 100.0),
                               T2_corr=1 / 50.0)
    prof = gs.evolve_lindblad(R_C, R_C, N_C, EO, XI0, TIMES, 0.1, T2=1 / 20.0,
                              dephasing_profile=(100.0, 50.0, 1.0, T))
    assert np.max(np.abs(const - prof)) < 1e-12


@pytest.mark.parametrize("beta", [0.5, 1.0, 2.0, 2.5])
def test_the_time_local_rate_accumulates_g(beta):
    rates = profile_rates((80.0, 20.0, beta, T), XI0)
    t0 = T_FLOOR * T
    for t in (0.3 * T, T, 1.4 * T):
        # held constant below t0, a power law above: a node at t0, a geometric grid after
        tau = np.concatenate([[0.0], np.geomspace(t0, t, 20001)]) * XI0
        g = np.array([rates(x) for x in tau])            # per unit tau
        acc = np.sum(0.5 * (g[1:] + g[:-1]) * np.diff(tau)[:, None], axis=0)
        want = accumulated_dephasing(1.0, beta, T, t) * np.array([80.0, 20.0])
        assert np.allclose(acc, want, rtol=1e-6), (beta, t, acc, want)


def test_dephasing_late_in_the_gate_approaches_the_final_state_decay():
    """A steep profile puts the dephasing at the end of the gate, where the spins are
    disentangled from the motion: the state is the ideal one with its coherences decayed."""
    G, f = 0.05, 0.4
    ideal = gs.evolve(R_C, R_C, N_C, EO, XI0, T, 0.0)
    late = gs.evolve_lindblad(R_C, R_C, N_C, EO, XI0, T, 0.0,
                              dephasing_profile=((1 - f) * G / T, f * G / T, 40.0, T))
    want = dephase_coherences(ideal, np.exp(-G), np.exp(-2 * (1 + f) * G))
    loss = abs(ideal[0, 3]) - abs(want[0, 3])
    assert abs(abs(late[0, 3]) - abs(want[0, 3])) < 0.1 * loss
    assert np.max(np.abs(np.diag(late) - np.diag(ideal))) < 0.1 * loss


def test_final_decay_is_the_average_over_gaussian_phase_noise():
    """Independent and common phases of variances 2 G_i and 2 G_c per ion, averaged by
    Gauss-Hermite quadrature, against the factors of G = G_i + G_c and f = G_c / G."""
    rng = np.random.default_rng(5)
    a = rng.normal(size=(4, 4)) + 1j * rng.normal(size=(4, 4))
    rho = a @ a.conj().T
    rho /= np.trace(rho)
    G_i, G_c = 0.03, 0.05
    x, w = np.polynomial.hermite_e.hermegauss(40)
    w = w / w.sum()
    xc, x1, x2 = np.meshgrid(x, x, x, indexing="ij")
    weight = (w[:, None, None] * w[None, :, None] * w[None, None, :]).ravel()
    p1 = (np.sqrt(2 * G_c) * xc + np.sqrt(2 * G_i) * x1).ravel()    # each ion's phase
    p2 = (np.sqrt(2 * G_c) * xc + np.sqrt(2 * G_i) * x2).ravel()
    z1, z2 = np.array([0.5, 0.5, -0.5, -0.5]), np.array([0.5, -0.5, 0.5, -0.5])
    ph = np.exp(-1j * (p1[:, None] * z1 + p2[:, None] * z2))         # exp(-i p_j Z_j / 2)
    avg = rho * np.einsum("k,ki,kj->ij", weight, ph, ph.conj())
    G, f = G_i + G_c, G_c / (G_i + G_c)
    got = dephase_coherences(rho, np.exp(-G), np.exp(-2 * (1 + f) * G))
    assert np.max(np.abs(got - avg)) < 1e-10


def test_a_final_decay_scales_the_contrast_and_keeps_the_populations():
    kw = dict(T2=np.inf, ndot=0.0, p_prep=0.0, p_det=0.0)
    a = gs.simulate_setting(R_C, R_C, N_C, EO, XI0, **kw)
    b = gs.simulate_setting(R_C, R_C, N_C, EO, XI0, coherence=(0.97, 0.9), **kw)
    assert np.allclose(a.pop, b.pop, atol=1e-14)
    assert b.parity_fit()[0] == pytest.approx(0.9 * a.parity_fit()[0], rel=1e-9)


@pytest.mark.parametrize("kwargs, needle", [
    ({"dephasing_profile": (10.0, 0.0, 0.0, T)}, "beta > 0"),
    ({"dephasing_profile": (-1.0, 0.0, 1.0, T)}, "rates must be finite and >= 0"),
    ({"dephasing_profile": (1.0, 2.0)}, "must be (rate, rate_common, beta, t_ref)"),
    ({"coherence": (1.2, 0.9)}, "coherence factors must lie in [0, 1]"),
])
def test_bad_slow_dephasing_is_one_clear_line(kwargs, needle):
    with pytest.raises(InputError) as exc:
        gs.simulate_setting(R_C, R_C, N_C, EO, XI0, **kwargs)
    assert needle in str(exc.value) and "\n" not in str(exc.value)
