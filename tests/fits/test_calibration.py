"""Amplitude and phase calibration: exactness, conventions and error-bar coverage."""

import numpy as np
import pytest

from dpdfit.simulation.aom_truth import (BraggAOM, HeterodyneNoise, PhotodiodeNoise,
                              simulate_amplitude_run, simulate_phase_run)
from dpdfit.fits.calibration import (amplitude_order_table, fit_amplitude, fit_phase,
                                nonmonotone_intervals)
from dpdfit.errors import FitError, InputError

AOM = BraggAOM()
GRID = np.linspace(0, 1, 201)


def test_exact_polynomial_power_is_recovered():
    a_true = np.array([1.0, 0.05, -0.9, 0.6, -0.25, 0.08, -0.02, 0.004])
    b1 = 1.7
    A = np.linspace(0, 1, 60)
    y = (A[:, None] ** np.arange(1, 9)) @ a_true
    P = (b1 * y) ** 2
    res = fit_amplitude(A, P, np.full(A.size, 1e-3))
    assert np.allclose(res.coefficients, a_true, rtol=0, atol=1e-8)
    assert res.A_corr == pytest.approx(a_true.sum(), abs=1e-9)
    assert res.power_scale == pytest.approx(b1 ** 2, rel=1e-9)
    assert res.chi2 < 1e-10
    assert res.coefficients[0] == 1.0 and res.stderr[0] == 0.0


def test_negative_powers_are_kept_not_dropped():
    rng = np.random.default_rng(3)
    d = simulate_amplitude_run(AOM, GRID, rng)
    assert (d.power < 0).any(), "the noise model must produce some negative powers"
    res = fit_amplitude(d.A, d.power, d.power_err)
    assert res.n_points == len(d) and res.dof == len(d) - 8
    assert np.isfinite(res.A_corr) and np.isfinite(res.A_corr_stderr)


def test_band_and_scalar_errors_agree():
    rng = np.random.default_rng(4)
    d = simulate_amplitude_run(AOM, GRID, rng)
    res = fit_amplitude(d.A, d.power, d.power_err)
    assert res.y_stderr(1.0) == pytest.approx(res.A_corr_stderr, rel=1e-9)
    assert res.y_stderr(0.0) == 0.0
    p = simulate_phase_run(AOM, GRID, rng)
    ph = fit_phase(p.A, p.phase_rad, p.phase_err)
    assert ph.phi_stderr(1.0) == pytest.approx(ph.phi_at_1_stderr, rel=1e-9)


def test_phase_window_excludes_explicitly():
    rng = np.random.default_rng(5)
    p = simulate_phase_run(AOM, GRID, rng)
    ph = fit_phase(p.A, p.phase_rad, p.phase_err, A_min=0.1)
    inside = int(((GRID >= 0.1) & (GRID <= 1)).sum())
    assert ph.n_points == inside and ph.n_excluded == GRID.size - inside
    assert ph.powers == (1, 2, 3, 4, 5)
    ph2 = fit_phase(p.A, p.phase_rad, p.phase_err, A_min=0.3, order=3)
    assert ph2.n_points == int((GRID >= 0.3).sum())
    with pytest.raises(InputError, match="window"):
        fit_phase(p.A, p.phase_rad, A_min=0.9, A_max=0.5)


def test_too_few_points():
    A = np.array([0.0, 0.2, 0.4, 0.6])
    with pytest.raises(FitError, match="needs at least 8 distinct amplitudes"):
        fit_amplitude(A, A ** 2, None, order=8)
    with pytest.raises(FitError, match="needs at least"):
        fit_phase(A, A, None, order=5, A_min=0.1)


def test_nonmonotone_intervals_exact():
    # y' = (1 - 2.5A)(1 - 1.5A) -> negative between 0.4 and 2/3
    iv = nonmonotone_intervals([1.0, -2.0, 1.25], [1, 2, 3])
    assert len(iv) == 1
    assert iv[0][0] == pytest.approx(0.4, abs=1e-12) and iv[0][1] == pytest.approx(2 / 3, abs=1e-12)
    assert nonmonotone_intervals([1.0, -0.1], [1, 2]) == []


def test_order_table_is_consistent():
    rng = np.random.default_rng(6)
    d = simulate_amplitude_run(AOM, GRID, rng)
    tab = amplitude_order_table(d.A, d.power, d.power_err, range(3, 11))
    assert [r["order"] for r in tab] == list(range(3, 11))
    chi2 = np.array([r["chi2"] for r in tab])
    assert np.all(np.diff(chi2) <= 1e-6 * chi2[:-1])        # nested models
    for r in tab:
        assert r["aic"] == pytest.approx(-2 * r["log_likelihood"] + 2 * r["n_params"])
    # the cubic cannot describe the Bragg curve: it must be strongly disfavoured
    assert tab[0]["bic"] - min(r["bic"] for r in tab) > 100
    res8 = fit_amplitude(d.A, d.power, d.power_err, order=8)
    row8 = next(r for r in tab if r["order"] == 8)
    assert row8["A_corr"] == pytest.approx(res8.A_corr, rel=1e-10)


# ----------------------------------------------------------------- statistical tests


def _amp_coverage(n_rep, seed, with_err, noise):
    rng = np.random.default_rng(seed)
    truth = AOM.true_A_corr
    est, se = np.empty(n_rep), np.empty(n_rep)
    for i in range(n_rep):
        d = simulate_amplitude_run(AOM, GRID, rng, noise)
        r = fit_amplitude(d.A, d.power, d.power_err if with_err else None)
        est[i], se[i] = r.A_corr, r.A_corr_stderr
    return est, se, truth


@pytest.mark.slow
def test_A_corr_coverage_with_power_err():
    """1-sigma interval of A_corr covers the truth in 68 +/- 3 % of 1000 calibrations."""
    est, se, truth = _amp_coverage(1000, 2026, True, PhotodiodeNoise())
    cover = np.mean(np.abs(est - truth) <= se)
    assert 0.65 <= cover <= 0.71, cover
    # the estimator is unbiased to well within its error bar
    assert abs(est.mean() - truth) < 0.1 * se.mean()
    # the reported error agrees with the scatter of the estimates
    assert est.std(ddof=1) / se.mean() == pytest.approx(1.0, abs=0.06)


@pytest.mark.slow
def test_A_corr_coverage_sigma_from_residuals():
    """Without power_err (homoscedastic detector noise, estimated from residuals)."""
    est, se, truth = _amp_coverage(1000, 77, False, PhotodiodeNoise(sigma_0=1e-3, rel=0.0))
    cover = np.mean(np.abs(est - truth) <= se)
    assert 0.65 <= cover <= 0.71, cover


def _phase_coverage(n_rep, seed, with_err, noise):
    rng = np.random.default_rng(seed)
    truth = AOM.true_phi_1
    est, se = np.empty(n_rep), np.empty(n_rep)
    for i in range(n_rep):
        p = simulate_phase_run(AOM, GRID, rng, noise)
        r = fit_phase(p.A, p.phase_rad, p.phase_err if with_err else None)
        est[i], se[i] = r.phi_at_1, r.phi_at_1_stderr
    return est, se, truth


@pytest.mark.slow
def test_phi1_coverage_with_phase_err():
    """1-sigma interval of phi(1) covers the truth in 68 +/- 3 % of 1000 calibrations."""
    est, se, truth = _phase_coverage(1000, 11, True, HeterodyneNoise())
    cover = np.mean(np.abs(est - truth) <= se)
    assert 0.65 <= cover <= 0.71, cover
    assert abs(est.mean() - truth) < 0.1 * se.mean()


@pytest.mark.slow
def test_phi1_coverage_sigma_from_residuals():
    """Phase noise nearly constant above A=0.3: fit there without phase_err."""
    rng = np.random.default_rng(12)
    truth = AOM.true_phi_1
    hits = 0
    for _ in range(1000):
        p = simulate_phase_run(AOM, GRID, rng, HeterodyneNoise(leak=0))
        # homoscedastic version of the data: replace noise by constant-sigma noise
        phase = AOM.phase(p.A) + 1e-3 * rng.standard_normal(len(p))
        r = fit_phase(p.A, phase, None)
        hits += abs(r.phi_at_1 - truth) <= r.phi_at_1_stderr
    assert 0.65 <= hits / 1000 <= 0.71, hits / 1000
