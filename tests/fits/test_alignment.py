"""Alignment fit (alpha, delta) and the time-resolved population model."""

import numpy as np
import pytest

from dpdfit.models import gate_sim
from dpdfit.fits.alignment import align, xi0_band
from dpdfit.errors import FitError, InputError
from dpdfit.models.fidelity import cardioid_populations
from dpdfit.analyses.sweep import SweepConfig, run_sweep
from dpdfit.simulation.gate_points import ALPHA, DELTA, SDB, simulated_gate
from dpdfit.simulation.aom_truth import truth_poly_tf


@pytest.fixture(scope="module")
def sweep():
    return run_sweep(truth_poly_tf(), SweepConfig(amplitudes=np.linspace(0.3, 0.9, 25)))


def test_band_formula():
    assert xi0_band(5.0, 0.2) == pytest.approx(5.0 * np.log(10) / 20 * 0.2)
    assert np.log(10) / 20 * 0.2 == pytest.approx(0.023, abs=5e-4)    # paper: ~2.3 %


@pytest.mark.slow
def test_alpha_delta_coverage(sweep):
    """alpha and delta are recovered within 1 sigma in >= 60 % and 2 sigma in >= 93 %."""
    rng = np.random.default_rng(5)
    hits1, hits2, n = np.zeros(2), np.zeros(2), 500
    for _ in range(n):
        fit = align(simulated_gate(sweep, rng), sweep, SDB)
        z = np.abs([(fit.alpha_khz - ALPHA) / fit.alpha_khz_err, (fit.delta - DELTA) / fit.delta_err])
        hits1 += z <= 1
        hits2 += z <= 2
    assert np.all(hits1 / n >= 0.60) and np.all(hits2 / n >= 0.93), (hits1 / n, hits2 / n)
    assert np.all(hits1 / n <= 0.76)                   # not over-covering either


def test_fit_outputs(sweep):
    fit = align(simulated_gate(sweep, np.random.default_rng(1)), sweep)
    d = fit.to_dict()
    for k in ("alpha_khz", "alpha_khz_err", "delta", "delta_err", "correlation", "redchi"):
        assert np.isfinite(d[k])
    assert abs(d["correlation"]) < 0.5
    assert {"r_rel", "F_PD", "eta_bar", "resid_h", "resid_v"} <= set(fit.points.columns)
    assert "alpha" in fit.report()


def test_bad_input(sweep):
    g = simulated_gate(sweep, np.random.default_rng(2))
    with pytest.raises(InputError, match="lacks column"):
        align(g.drop(columns="F_err"), sweep)
    with pytest.raises(FitError, match="at least 2"):
        align(g.iloc[:1], sweep)
    bad = g.copy()
    bad.loc[0, "A"] = 0.95
    with pytest.raises(InputError, match="outside the sweep's range"):
        align(bad, sweep)


@pytest.mark.parametrize("nbar", [0.0, 0.1])
def test_time_scan_model_matches_exact_dynamics(nbar):
    """The closed-form ideal populations equal the brute-force engine's (no imperfections)."""
    xi0 = 4.6e3
    r = np.array([1.0, -1.0]) / np.sqrt(1.5)
    n = np.array([1, 2])
    eta_Omega0 = gate_sim.calibrate_xi0(r, r, n, 1.0)
    eta_Omega0 = xi0 / eta_Omega0
    t = np.linspace(0, 1.3 / xi0, 14)
    exact = gate_sim.populations(r, r, n, eta_Omega0, xi0, t, nbar=nbar, T2=np.inf, ndot=0.0,
                                 p_prep=0.0, p_det=0.0)
    model = cardioid_populations(t, xi0, nbar)
    assert np.allclose(model, exact, atol=1e-7)
