"""What the diagnosis's null model learns from a campaign: noise floor,
tone repeatability, the calibration photodiode's and phase measurement's noise,
and the exact preparation/detection branches of the gate engine."""

import numpy as np
import pytest

from dpdfit.models import gate_sim
from dpdfit.analyses.diagnosis.observables.tone_features import debias_tones
from dpdfit.fits.photodiode import fit_phase_noise, fit_power_noise
from dpdfit.fits.tone_noise import MEDIAN_CHI2_1, estimate_noise_floor, robust_scale


def _im_series(rng, N0, A, k):
    """Rician powers of IM tones c = sqrt(k) A^3 with complex noise of mean power N0."""
    c = np.sqrt(k)[None, :] * A[:, None] ** 3
    n = np.sqrt(N0 / 2) * (rng.standard_normal(c.shape) + 1j * rng.standard_normal(c.shape))
    return 10 * np.log10(np.abs(c + n) ** 2)


@pytest.mark.slow
def test_noise_floor_estimate_is_unbiased_and_its_error_covers():
    """IM tones rising as A^6 out of a floor: the estimate of the floor (dB) has no
    bias beyond 0.15 of its error and its 1-sigma interval covers 68 +/- 6 %
    (300 simulated spectra, 8 IM series of 40 amplitudes)."""
    rng = np.random.default_rng(5)
    A = np.linspace(0.05, 1.0, 40)
    true_db = -92.0
    pulls = []
    for _ in range(300):
        k = 10 ** rng.uniform(-3.5, -2.0, 8)
        P = _im_series(rng, 10 ** (true_db / 10), A, k)
        f = estimate_noise_floor(P, A, np.ones(8, bool))
        assert f.method.startswith("estimated")
        pulls.append((f.floor_db - true_db) / f.floor_err_db)
    pulls = np.array(pulls)
    assert abs(pulls.mean()) < 0.15
    assert 0.62 <= np.mean(np.abs(pulls) <= 1) <= 0.74


def test_noise_floor_not_reached_gives_an_upper_limit():
    A = np.linspace(0.5, 1.0, 10)
    P = 10 * np.log10(1e-4 * A[:, None] ** 6 * np.ones((1, 4)))
    f = estimate_noise_floor(P, A, np.ones(4, bool))
    assert f.method.startswith("upper limit") and np.isnan(f.floor_err_db)
    assert f.floor_db <= P.min() + 1e-9


@pytest.mark.slow
def test_debiased_tone_power_is_unbiased_at_moderate_snr():
    rng = np.random.default_rng(2)
    N0, c2 = 1.0, 10 ** 2.5                   # 25 dB over the mean floor
    n = np.sqrt(N0 / 2) * (rng.standard_normal(200000) + 1j * rng.standard_normal(200000))
    P = 10 * np.log10(np.abs(np.sqrt(c2) + n) ** 2)
    val, err = debias_tones(P, N0)
    assert abs(np.mean(10 ** (val / 10)) / c2 - 1) < 2e-3
    # the error describes the scatter of the dB reading
    assert abs(np.std(val) / np.median(err) - 1) < 0.03


@pytest.mark.slow
def test_robust_scale_recovers_the_white_noise_under_a_smooth_misfit():
    """Second differences: a smooth misfit of 20 sigma does not inflate the estimate."""
    rng = np.random.default_rng(3)
    A = np.linspace(0.05, 1, 40)
    est = []
    for _ in range(200):
        s_true = 0.03
        known = np.full((40, 8), 0.01)
        r = (rng.standard_normal((40, 8)) * np.hypot(known, s_true)
             + 0.6 * np.sin(3 * A)[:, None] ** 2)          # smooth, ~20 sigma
        d = (r[:-2] - 2 * r[1:-1] + r[2:]).ravel() ** 2
        v = (known[:-2] ** 2 + 4 * known[1:-1] ** 2 + known[2:] ** 2).ravel()
        est.append(robust_scale(d, v, np.full(d.size, 6.0)))
    est = np.array(est)
    assert abs(np.median(est) / 0.03 - 1) < 0.05
    # no extra noise: the known variance explains the scatter
    d = (rng.standard_normal(300) * np.sqrt(6.0)) ** 2
    assert robust_scale(d, np.full(300, 6.0), np.full(300, 6.0)) < 0.2
    assert MEDIAN_CHI2_1 == pytest.approx(0.4549, abs=1e-4)


def test_photodiode_noise_model_is_learnt_from_the_runs():
    """sigma(P)^2 = a^2 + (b P)^2 of 30 simulated runs is recovered to 10 %."""
    from dpdfit.fits.calibration import fit_amplitude
    rng = np.random.default_rng(4)
    A = np.linspace(0, 1, 101)
    a, b = 2e-5, 2e-4
    As, Ps, runs = [], [], []
    for r in range(30):
        P = (np.sin(np.pi / 2 * A * (1 + 0.01 * rng.standard_normal())) ** 2) * 1.1
        Ps.append(P + rng.standard_normal(A.size) * np.sqrt(a ** 2 + (b * P) ** 2))
        As.append(A)
        runs.append(np.full(A.size, r))
    noise = fit_power_noise(np.concatenate(As), np.concatenate(Ps), np.concatenate(runs))
    assert noise.n_runs == 30
    assert noise.a == pytest.approx(a, rel=0.1) and noise.b == pytest.approx(b, rel=0.1)
    assert fit_power_noise(A, Ps[0], np.zeros(A.size)) is None       # one run: no model
    del fit_amplitude


def test_phase_noise_model_is_learnt_from_the_runs():
    rng = np.random.default_rng(6)
    A = np.linspace(0, 1, 101)
    c, d = 2e-4, 1.5e-4
    As, ph, runs = [], [], []
    for r in range(8):
        phi = 0.28 * A ** 2.2
        sig = np.sqrt(c ** 2 + (d / np.maximum(A, 1e-6)) ** 2)
        ph.append(phi + rng.standard_normal(A.size) * sig)
        As.append(A)
        runs.append(np.full(A.size, r))
    noise = fit_phase_noise(np.concatenate(As), np.concatenate(ph), np.concatenate(runs))
    assert noise.c == pytest.approx(c, rel=0.15) and noise.d == pytest.approx(d, rel=0.15)


# --------------------------------------------------------------------------- engine

def _tones():
    r = 1 / np.sqrt(1.5)
    n = np.array([1, 2])
    b = np.array([r, -r], dtype=complex)
    return b, b.copy(), n, gate_sim.calibrate_xi0(b, b, n, 1.0)


def test_preparation_branches_at_time_zero_are_the_analytic_mixture():
    """Before any drive, spectators read 0, flipped ions 1; detection errors (e01, e10)
    then act as the per-ion confusion matrix."""
    b, c, n, unit = _tones()
    xi = 4000.0
    ps, pf, e01, e10 = 0.004, 0.007, 3e-4, 1e-4
    pop = gate_sim.populations(b, c, n, xi / unit, xi, times=np.array([0.0]), p_prep=ps,
                               p_flip=pf, p_det=(e01, e10), T2=np.inf, ndot=0.0)[0]
    one = {0: 1 - pf, 1: pf}                          # a spectator reads 0 like |0>
    C = np.array([[1 - e01, e10], [e01, 1 - e10]])
    read = {k: sum(C[k, t] * v for t, v in one.items()) for k in (0, 1)}
    np.testing.assert_allclose(pop, [read[0] ** 2, 2 * read[0] * read[1], read[1] ** 2],
                               atol=1e-12)


def test_setting_branches_mixed_analytically_equal_the_engine():
    """The diagnosis mixes the branches analytically: equal to simulate_setting's exact
    mixture (|11> approximated by the bit-flipped |00> branch: below 1e-5 at p_flip 0.003)."""
    b, c, n, unit = _tones()
    xi = 4000.0
    kw = dict(nbar=0.1, T2=0.05, ndot=5.0, rtol=1e-9, atol=1e-11)
    ps, pf, det = 0.002, 0.003, (1e-4, 2e-4)
    ref = gate_sim.simulate_setting(b, c, n, xi / unit, xi, p_prep=ps, p_flip=pf, p_det=det,
                                    **kw)
    br = gate_sim.setting_branches(b, c, n, xi / unit, xi, **kw)
    pop = gate_sim.confusion(gate_sim.mix_branches(br["p2"][0], br["p1"][0], ps, pf,
                                                   br["p2_01"][0], None, br["p1_1"][0]), det)
    got = np.array([pop[0], pop[1] + pop[2], pop[3]])
    np.testing.assert_allclose(got, ref.pop, atol=1e-5)
    par = gate_sim.confusion(gate_sim.mix_branches(br["par2"], br["par1"], ps, pf,
                                                   br["par2_01"], None, br["par1_1"]), det)
    np.testing.assert_allclose(par[:, 0] + par[:, 3], ref.parity_probs[:, 0]
                               + ref.parity_probs[:, 2], atol=1e-5)


def test_correlated_dephasing_costs_the_bell_contrast_more_than_independent():
    """Common-mode noise with the same single-ion coherence time decays |00><11| twice as
    fast as independent noise: the gate's parity contrast loss is larger; for one ion the
    two are the same process."""
    b, c, n, unit = _tones()
    xi = 4000.0
    T = 1 / xi
    kw = dict(nbar=0.1, ndot=0.0, rtol=1e-9, atol=1e-11)
    one_i = gate_sim.evolve_lindblad(b, c, n, xi / unit, xi, T, n_ions=1, T2=0.01, **kw)
    one_c = gate_sim.evolve_lindblad(b, c, n, xi / unit, xi, T, n_ions=1, T2_corr=0.01, **kw)
    np.testing.assert_allclose(one_i, one_c, atol=1e-10)
    ind = gate_sim.evolve_lindblad(b, c, n, xi / unit, xi, T, T2=0.01, **kw)
    cor = gate_sim.evolve_lindblad(b, c, n, xi / unit, xi, T, T2_corr=0.01, **kw)
    ideal = gate_sim.evolve_lindblad(b, c, n, xi / unit, xi, T, **kw)
    loss = {k: 2 * abs(ideal[0, 3]) - 2 * abs(r[0, 3]) for k, r in
            (("ind", ind), ("cor", cor))}
    assert loss["cor"] > 1.3 * loss["ind"] > 0
