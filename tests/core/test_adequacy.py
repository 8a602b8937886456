"""Model adequacy: the reduced chi-square against its 99 % range.

A correct model is flagged (``model_adequate is False``) 1 % of the time: over
300 seeded replicates per fit kind the count of flags must lie in the
binomial 99.9 % band of Binomial(300, 0.01), and the pooled count over the four
kinds in that of Binomial(1200, 0.01).  Birge-scaled errors are offered beside
the absolute ones, which never change.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from dpdfit.analyses.sweep import SweepConfig, run_sweep
from dpdfit.core.adequacy import redchi_range
from dpdfit.fits.alignment import align
from dpdfit.fits.calibration import fit_amplitude, fit_phase
from dpdfit.fits.polyfit import polyfit
from dpdfit.recordings.tables import read_calibration
from dpdfit.simulation.gate_points import simulated_gate
from dpdfit.simulation.aom_truth import truth_poly_tf
from tests.helpers.built_once import built_once
from tests.helpers.bundled_data import AOM

N_REP = 300
P_FLAG = 0.01


def _band(n: int, p: float = P_FLAG, level: float = 0.999) -> tuple[int, int]:
    tail = (1 - level) / 2
    return int(stats.binom.ppf(tail, n, p)), int(stats.binom.isf(tail, n, p))


def test_range_is_the_central_99_percent_of_chi2_over_dof():
    lo, hi = redchi_range(18)
    assert lo == pytest.approx(stats.chi2.ppf(0.005, 18) / 18)
    assert hi == pytest.approx(stats.chi2.ppf(0.995, 18) / 18)
    assert stats.chi2.cdf(hi * 18, 18) - stats.chi2.cdf(lo * 18, 18) == pytest.approx(0.99)


def _polyfit_flags(rng) -> int:
    x = np.linspace(0, 1, 30)
    truth = 1 + 2 * x - 3 * x ** 2
    return sum(polyfit(x, truth + 0.1 * rng.standard_normal(30), range(3), sigma=0.1)
               .model_adequate is False for _ in range(N_REP))


def _amplitude_flags(rng) -> int:
    d = read_calibration(AOM / "calibration_amplitude.csv", "amplitude")
    truth = fit_amplitude(d.A, d.value, d.error)
    p0 = truth.power(d.A)
    return sum(fit_amplitude(d.A, p0 + d.error * rng.standard_normal(d.A.size), d.error)
               .model_adequate is False for _ in range(N_REP))


def _phase_flags(rng) -> int:
    d = read_calibration(AOM / "calibration_phase.csv", "phase")
    truth = fit_phase(d.A, d.value, d.error)
    p0 = truth.phi(d.A)
    return sum(fit_phase(d.A, p0 + d.error * rng.standard_normal(d.A.size), d.error)
               .model_adequate is False for _ in range(N_REP))


def _alignment_flags(rng) -> int:
    sweep = run_sweep(truth_poly_tf(), SweepConfig(amplitudes=np.linspace(0.3, 0.9, 25)))
    return sum(align(simulated_gate(sweep, rng), sweep).model_adequate is False
               for _ in range(N_REP))


@pytest.fixture(scope="module")
def flag_counts(tmp_path_factory):
    """Flags of a correct model over N_REP seeded replicates per fit kind (counted once
    per test run: the five tests may run on both xdist workers)."""
    return built_once(tmp_path_factory, "adequacy_flag_counts", lambda folder: {
        name: f(np.random.default_rng(seed)) for name, f, seed in [
            ("polyfit", _polyfit_flags, 1601), ("amplitude", _amplitude_flags, 1602),
            ("phase", _phase_flags, 1603), ("alignment", _alignment_flags, 1604)]})


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["polyfit", "amplitude", "phase", "alignment"])
def test_correct_model_is_flagged_about_1_percent(flag_counts, kind):
    lo, hi = _band(N_REP)
    assert lo <= flag_counts[kind] <= hi, (kind, flag_counts[kind], (lo, hi))


@pytest.mark.slow
def test_pooled_flag_rate(flag_counts):
    lo, hi = _band(4 * N_REP)
    assert lo <= sum(flag_counts.values()) <= hi, (flag_counts, (lo, hi))


def test_wrong_model_is_flagged_and_errors_stay_absolute():
    rng = np.random.default_rng(7)
    x = np.linspace(0, 1, 30)
    y = 1 + 2 * x - 3 * x ** 2 + 0.05 * rng.standard_normal(30)
    fit = polyfit(x, y, range(2), sigma=0.05)                 # a straight line: wrong
    ok = polyfit(x, y, range(3), sigma=0.05)
    assert fit.model_adequate is False and ok.model_adequate is True
    f = math.sqrt(fit.reduced_chi2)
    assert fit.birge_factor == pytest.approx(f)
    assert np.allclose(fit.stderr_birge, fit.stderr * f)
    assert np.allclose(fit.stderr, np.sqrt(np.diag(fit.covariance)))   # not rescaled
    d = fit.to_dict()
    assert d["model_adequate"] is False and d["birge_factor"] == pytest.approx(f)
    assert d["redchi_range_99"] == pytest.approx(list(redchi_range(28)))
    assert "does not describe the data" in fit.report() and "Birge" in fit.report()
    assert "within its 99 % range" in ok.report()


def test_too_small_chi2_says_sigmas_too_large():
    x = np.linspace(0, 1, 30)
    fit = polyfit(x, 1 + x + 1e-3 * np.sin(40 * x), range(2), sigma=0.1)
    assert fit.model_adequate is False and fit.reduced_chi2 < fit.redchi_range_99[0]
    text = fit.report()
    assert "sigmas look too large" in text and "Birge-scaled" not in text
    assert "Birge-scaled" not in fit.display_text()


def test_not_testable_without_given_sigma():
    x = np.linspace(0, 1, 30)
    fit = polyfit(x, 1 + x + 0.1 * np.sin(40 * x), range(2))     # sigma from residuals
    assert fit.sigma_source == "residuals"
    assert fit.model_adequate is None and fit.birge_factor is None
    assert np.array_equal(fit.stderr_birge, fit.stderr)
    assert "adequacy" not in fit.report() and "does not describe" not in fit.report()


def test_bundled_campaign_alignment_is_inadequate(bundled_alignment):
    al = bundled_alignment
    assert al.redchi == pytest.approx(20.7, abs=0.05)
    assert al.model_adequate is False
    text = al.report()
    assert "F = F_est + delta" in text and "does not describe the data" in text
    f = math.sqrt(al.redchi)
    assert al.alpha_khz_err_birge == pytest.approx(al.alpha_khz_err * f)
    assert al.delta_err_birge == pytest.approx(al.delta_err * f)
    assert f"+/- {al.alpha_khz_err_birge:.4g} kHz" in text
    d = al.to_dict()
    assert d["chi2_vertical"] > 100 * d["chi2_horizontal"]     # the F residuals, not xi0
    assert d["chi2_vertical"] + d["chi2_horizontal"] == pytest.approx(al.chi2)
