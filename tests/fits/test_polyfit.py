"""Tests of dpdfit.fits.polyfit: accuracy against 50-digit mpmath, API, error convention."""

from __future__ import annotations

import dataclasses
import importlib
import json
import math

import mpmath
import numpy as np
import pytest
from scipy import stats

from dpdfit.fits.polyfit import double_double as _dd
from dpdfit.errors import FitError, InputError
from dpdfit.fits.polyfit import PolyFitResult, parse_powers, polyfit
from dpdfit.simulation.polyfit_problems import hard_case, mp_reference, no_constant_case

DICT_KEYS = {
    "powers", "coefficients", "stderr", "covariance", "residual_std", "chi2", "dof",
    "reduced_chi2", "r2", "aic", "bic", "log_likelihood", "condition_number",
    "condition_number_scaled", "n_points", "sigma_source", "refinement_iterations",
    "converged",
    # model adequacy
    "model_adequate", "redchi_range_99", "birge_factor", "chi2_p_value", "stderr_birge",
}


# --------------------------------------------------------------------------
# against the 50-digit reference solution (benchmarks/polyfit_problems.py)
# --------------------------------------------------------------------------
def worst_rel(values, reference):
    """max_j |values_j - ref_j| / |ref_j|, in float."""
    with mpmath.workdps(50):
        return max(float(abs((mpmath.mpf(float(v)) - r) / r)) for v, r in zip(values, reference))


CASES = [
    pytest.param(hard_case, True, 1e-11, id="deg10-const-[-9,-3]-sigma"),
    pytest.param(hard_case, False, 1e-11, id="deg10-const-[-9,-3]-nosigma"),
    pytest.param(no_constant_case, True, 1e-12, id="powers1..8-[0,1]-sigma"),
    pytest.param(no_constant_case, False, 1e-12, id="powers1..8-[0,1]-nosigma"),
]


@pytest.fixture(scope="module")
def references():
    cache = {}

    def get(case, with_sigma):
        key = (case.__name__, with_sigma)
        if key not in cache:
            x, y, powers, sigma = case(with_sigma)
            cache[key] = mp_reference(x, y, powers, sigma)
        return cache[key]
    return get


# --------------------------------------------------------------------------
# accuracy
# --------------------------------------------------------------------------
@pytest.mark.parametrize("case, with_sigma, rtol", CASES)
def test_matches_mpmath_reference(case, with_sigma, rtol, references):
    x, y, powers, sigma = case(with_sigma)
    ref = references(case, with_sigma)
    res = polyfit(x, y, powers, sigma=sigma)
    assert res.converged
    assert worst_rel(res.coefficients, ref["coefficients"]) <= rtol
    assert worst_rel(res.stderr, ref["stderr"]) <= rtol
    assert worst_rel([res.chi2], [ref["chi2"]]) <= rtol
    assert worst_rel([res.residual_std], [ref["residual_std"]]) <= rtol
    assert res.sigma_source == ("given" if with_sigma else "residuals")


def test_hard_case_is_really_hard_for_plain_lstsq(references):
    x, y, powers, _ = hard_case(False)
    V = x[:, None] ** np.array(powers, dtype=float)
    assert np.linalg.cond(V) > 1e14
    assert polyfit(x, y, powers).condition_number > 1e14
    ref = references(hard_case, False)["coefficients"]
    # plain double least squares loses most of its digits here: numpy's default
    # cut-off even drops the smallest singular value (rank 10 of 11) ...
    assert worst_rel(np.linalg.lstsq(V, y, rcond=None)[0], ref) > 1e-9
    # ... and without the cut-off it is backward stable, i.e. ~cond * eps off
    assert worst_rel(np.linalg.lstsq(V, y, rcond=-1)[0], ref) > 1e-9


def test_covariance_matrix_matches_reference(references):
    x, y, powers, sigma = hard_case(True)
    res = polyfit(x, y, powers, sigma=sigma)
    cov = references(hard_case, True)["cov"]
    p = len(powers)
    with mpmath.workdps(50):
        worst = max(float(abs((mpmath.mpf(float(res.covariance[i, j])) - cov[i, j]) / cov[i, j]))
                    for i in range(p) for j in range(p))
    assert worst <= 1e-11
    np.testing.assert_array_equal(res.covariance, res.covariance.T)


def test_predict_stderr_is_accurate_where_v_C_v_cancels(references):
    x, y, powers, sigma = hard_case(False)
    res = polyfit(x, y, powers, sigma=sigma)
    cov = references(hard_case, False)["cov"]
    for x0 in (-9.0, -6.1, -3.0, -2.5):
        with mpmath.workdps(50):
            v = mpmath.matrix([mpmath.mpf(x0) ** k for k in powers])
            exact = mpmath.sqrt((v.T * cov * v)[0])
            got = res.predict_stderr(x0)
            assert float(abs((got - exact) / exact)) < 1e-6
    band = res.predict_stderr(np.array([[-9.0, -6.0], [-4.0, -3.0]]))
    assert band.shape == (2, 2) and np.all(band > 0)


# --------------------------------------------------------------------------
# exact data, bookkeeping, statistics
# --------------------------------------------------------------------------
def test_exact_polynomial_is_recovered():
    # dyadic x and small coefficients: y is exact in double, so is the LS solution
    x = np.arange(-9.0, -2.99, 0.125)
    truth = np.zeros(11)
    truth[:4] = [3.0, -2.0, 0.5, 0.25]
    y = np.polynomial.polynomial.polyval(x, truth)
    res = polyfit(x, y, range(11))
    np.testing.assert_allclose(res.coefficients, truth, rtol=1e-15, atol=1e-25)
    assert res.chi2 < 1e-50
    np.testing.assert_array_equal(res.predict(x), y)

    x = np.arange(65) / 64
    y = x - 0.5 * x ** 2 + 0.125 * x ** 5
    res = polyfit(x, y, [5, 1, 2, 3, 4, 6, 7, 8], sigma=0.1)   # any order
    assert res.powers == (1, 2, 3, 4, 5, 6, 7, 8)
    np.testing.assert_allclose(res.coefficients, [1, -0.5, 0, 0, 0.125, 0, 0, 0],
                               rtol=1e-15, atol=1e-25)


def test_exact_power_of_two_scale_equivariance():
    # all scalings are by powers of two, so rescaling x or y by 2**k changes
    # nothing but exponents -- also far outside the range where the dd
    # splitting (|a| < 1e300) or the squares of y would overflow naively
    x, y, powers, sigma = hard_case(True)
    base = polyfit(x, y, powers, sigma=sigma)
    for k in (400, -400):
        big = polyfit(x, y * 2.0 ** k, powers, sigma=sigma * 2.0 ** k)
        np.testing.assert_array_equal(big.coefficients, base.coefficients * 2.0 ** k)
        np.testing.assert_array_equal(big.stderr, base.stderr * 2.0 ** k)
        assert big.chi2 == base.chi2
        est = polyfit(x, y * 2.0 ** k, powers)
        ref = polyfit(x, y, powers)
        np.testing.assert_array_equal(est.stderr, ref.stderr * 2.0 ** k)
    wide = polyfit(x * 2.0 ** 20, y, powers, sigma=sigma)
    shift = 2.0 ** (-20 * np.array(powers, dtype=float))
    np.testing.assert_array_equal(wide.coefficients, base.coefficients * shift)
    np.testing.assert_array_equal(wide.stderr, base.stderr * shift)


def test_statistics_definitions():
    rng = np.random.default_rng(3)
    x = np.linspace(-1, 2, 25)
    sigma = 0.1 + 0.05 * x ** 2
    y = 1 + x - 0.3 * x ** 2 + sigma * rng.standard_normal(x.size)

    res = polyfit(x, y, range(3), sigma=sigma)
    n, p = x.size, 3
    r = (y - res.predict(x)) / sigma
    assert res.chi2 == pytest.approx(np.sum(r ** 2), rel=1e-12)
    assert res.dof == n - p and res.n_points == n
    assert res.reduced_chi2 == pytest.approx(res.chi2 / (n - p), rel=1e-15)
    assert res.residual_std == pytest.approx(math.sqrt(res.chi2 / (n - p)), rel=1e-15)
    w = 1 / sigma ** 2
    ybar = np.sum(w * y) / np.sum(w)
    assert res.r2 == pytest.approx(1 - res.chi2 / np.sum(w * (y - ybar) ** 2), rel=1e-12)
    m2lnl = res.chi2 + np.sum(np.log(2 * np.pi * sigma ** 2))
    assert res.log_likelihood == pytest.approx(-0.5 * m2lnl, rel=1e-12)
    assert res.aic == pytest.approx(m2lnl + 2 * p, rel=1e-12)
    assert res.bic == pytest.approx(m2lnl + p * np.log(n), rel=1e-12)
    np.testing.assert_allclose(res.stderr, np.sqrt(np.diag(res.covariance)), rtol=1e-15)

    # sigma estimated from the residuals; uncentred R^2 without a constant
    res = polyfit(x, y, [1, 2])
    rss = np.sum((y - res.predict(x)) ** 2)
    assert res.chi2 == pytest.approx(rss, rel=1e-12)
    assert res.r2 == pytest.approx(1 - rss / np.sum(y ** 2), rel=1e-12)
    m2lnl = n * np.log(2 * np.pi * rss / n) + n
    assert res.log_likelihood == pytest.approx(-0.5 * m2lnl, rel=1e-12)
    assert res.aic == pytest.approx(m2lnl + 2 * 3, rel=1e-12)
    assert res.bic == pytest.approx(m2lnl + 3 * np.log(n), rel=1e-12)
    V = x[:, None] ** np.array([1.0, 2.0])
    cov = rss / (n - 2) * np.linalg.inv(V.T @ V)       # well conditioned here
    np.testing.assert_allclose(res.covariance, cov, rtol=1e-10)


def test_sigma_given_is_absolute_not_rescaled():
    x = np.linspace(0, 1, 20)
    y = 2 * x + 0.1 * np.sin(37 * x)
    a = polyfit(x, y, [0, 1], sigma=0.01)
    b = polyfit(x, y, [0, 1], sigma=np.full(x.size, 0.01))
    c = polyfit(x, y, [0, 1], sigma=0.02)
    np.testing.assert_array_equal(a.covariance, b.covariance)
    np.testing.assert_allclose(c.covariance, 4 * a.covariance, rtol=1e-14)
    assert a.reduced_chi2 > 10          # the bad model does not inflate the errors
    np.testing.assert_allclose(a.coefficients, c.coefficients, rtol=1e-14)


def test_zero_dof_with_sigma():
    x = np.array([0.0, 1.0, 2.0])
    res = polyfit(x, [1.0, 2.0, 5.0], range(3), sigma=[0.1, 0.1, 0.2])
    assert res.dof == 0
    assert math.isnan(res.reduced_chi2) and math.isnan(res.residual_std)
    np.testing.assert_allclose(res.coefficients, [1, 0, 1], atol=1e-14)
    assert np.all(np.isfinite(res.stderr))
    assert "no residual degrees of freedom" in res.report()


def test_result_is_frozen_and_serialisable():
    x = np.linspace(0, 1, 12)
    res = polyfit(x, 1 + x ** 2 + 0.01 * np.cos(9 * x), range(3))
    assert isinstance(res, PolyFitResult)
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.chi2 = 0.0
    for name in ("coefficients", "covariance", "stderr"):
        arr = getattr(res, name)
        assert not arr.flags.writeable
        with pytest.raises(ValueError):
            arr[0] = 1.0
    d = res.to_dict()
    assert set(d) == DICT_KEYS
    text = json.dumps(d)
    back = json.loads(text)
    assert back["powers"] == [0, 1, 2]
    assert back["coefficients"] == res.coefficients.tolist()
    assert back["sigma_source"] == "residuals" and isinstance(back["converged"], bool)
    assert isinstance(back["dof"], int) and isinstance(back["refinement_iterations"], int)


def test_report_mentions_the_essentials():
    x, y, powers, sigma = hard_case(True)
    text = polyfit(x, y, powers, sigma=sigma).report()
    for needle in ("chi-square", "reduced chi-square", "R-squared", "AIC", "BIC",
                   "condition number", "converged", "+/-", "absolute", "c10"):
        assert needle in text
    text = polyfit(x, y, powers).report()
    assert "estimated from residuals" in text


def test_predict_matches_coefficients():
    x = np.linspace(-2, 2, 15)
    res = polyfit(x, x ** 3 - x + np.sin(x) * 1e-3, [1, 3, 4])
    x0 = np.array([-1.5, 0.0, 0.7])
    direct = sum(c * x0 ** k for c, k in zip(res.coefficients, res.powers))
    np.testing.assert_allclose(res.predict(x0), direct, rtol=1e-13, atol=1e-15)
    assert isinstance(res.predict(0.5), float)
    assert res.predict_stderr(0.0) == 0.0          # no constant: the curve is pinned at 0


# --------------------------------------------------------------------------
# powers and input validation
# --------------------------------------------------------------------------
@pytest.mark.parametrize("spec, expected", [
    ("0:10", tuple(range(11))), ("1:8", tuple(range(1, 9))), ("3:3", (3,)),
    ("1,2,5", (1, 2, 5)), (" 5, 1 ,2 ", (1, 2, 5)), ("0", (0,)),
])
def test_parse_powers(spec, expected):
    assert parse_powers(spec) == expected


@pytest.mark.parametrize("spec, match", [
    ("", "empty"), ("  ", "empty"), ("-1,2", "negative"), ("1,1", "duplicate"),
    ("5:2", "end 2 < start 5"), ("a,b", "bad power 'a'"), ("1.5", "bad power"),
    ("1:", "bad power range"), ("1,,2", "bad power ''"), ("0:-3", "bad power range"),
])
def test_parse_powers_rejects(spec, match):
    with pytest.raises(InputError, match=match):
        parse_powers(spec)


@pytest.mark.parametrize("powers, match", [
    ([], "no powers"), ([1, -2], "negative"), ([0, 2, 2], "duplicate"),
    ([1.5], "not an integer"), ([True], "not an integer"), (3, "iterable"),
])
def test_bad_powers(powers, match):
    with pytest.raises(InputError, match=match):
        polyfit(np.arange(5.0), np.arange(5.0), powers)


def test_string_powers_accepted():
    x = np.linspace(0, 1, 9)
    assert polyfit(x, x ** 2, "0:2").powers == (0, 1, 2)


X5 = np.arange(6.0)


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(x=[[1.0, 2.0]], y=[[1.0, 2.0]]), InputError, "x must be 1-D"),
    (dict(x=X5, y=X5[:5]), InputError, "differ in length"),
    (dict(x=np.r_[X5[:5], np.nan], y=X5), InputError, "x has 1 non-finite"),
    (dict(x=X5, y=np.r_[X5[:5], np.inf]), InputError, "y has 1 non-finite"),
    (dict(x=X5, y=X5, sigma=np.r_[1.0, 1, 1, 0, 1, 1]), InputError, "sigma must be > 0"),
    (dict(x=X5, y=X5, sigma=-1.0), InputError, "sigma must be > 0"),
    (dict(x=X5, y=X5, sigma=np.ones(3)), InputError, "sigma and x differ in length"),
    (dict(x=X5, y=X5, sigma=np.r_[1.0, 1, 1, np.nan, 1, 1]), InputError, "sigma has 1 non-finite"),
    (dict(x=["a"] * 6, y=X5), InputError, "x must be numeric"),
    (dict(x=X5[:3], y=X5[:3]), FitError, "3 points for 3 coefficients"),
    (dict(x=X5[:2], y=X5[:2], sigma=1.0), FitError, "2 points for 3 coefficients"),
    (dict(x=np.r_[1.0, 1, 1, 2, 2, 2], y=X5), FitError, "only 2 distinct x"),
    (dict(x=np.r_[-1.0, 1, -2, 2, -3, 3], y=X5, powers=[2, 4, 6, 8]), FitError,
     "rank deficient"),
    (dict(x=np.r_[0.0, 0, 0, 0, 1, 2], y=X5, powers=[1, 2, 3]), FitError, "rank deficient"),
    (dict(x=np.linspace(1e30, 2e30, 20), y=np.ones(20), powers=range(12)), FitError,
     "overflows"),
])
def test_bad_input_raises(kwargs, error, match):
    kwargs.setdefault("powers", range(3))
    with pytest.raises(error, match=match):
        polyfit(**kwargs)


def test_refinement_status_is_reported(monkeypatch):
    module = importlib.import_module("dpdfit.fits.polyfit.refine")
    x, y, powers, sigma = hard_case(True)
    full = polyfit(x, y, powers, sigma=sigma)
    assert full.converged and 3 <= full.refinement_iterations <= 6
    # capped after 2 steps: ~7 digits short of the target -> warning, converged False
    monkeypatch.setattr(module, "REFINE_MAX_ITER", 2)
    with pytest.warns(RuntimeWarning, match="iterative refinement stopped after 2"):
        short = polyfit(x, y, powers, sigma=sigma)
    assert not short.converged and short.refinement_iterations == 2
    assert short.to_dict()["converged"] is False
    assert "NOT converged" in short.report()
    # a single step is no refinement at all: refuse
    monkeypatch.setattr(module, "REFINE_MAX_ITER", 1)
    with pytest.raises(FitError, match="too ill-conditioned"):
        polyfit(x, y, powers, sigma=sigma)


def test_errors_are_dpdfit_errors():
    with pytest.raises(ValueError):           # DpdfitError derives from ValueError
        polyfit([1.0, 2.0], [1.0, 2.0], [0, 1, 2])


# --------------------------------------------------------------------------
# double-double kernel
# --------------------------------------------------------------------------
def test_dd_kernels_against_mpmath():
    rng = np.random.default_rng(11)
    a = rng.standard_normal(200) * 10.0 ** rng.uniform(-8, 8, 200)
    b = rng.standard_normal(200) * 10.0 ** rng.uniform(-8, 8, 200)
    with mpmath.workdps(60):
        def val(d, i):
            return mpmath.mpf(float(d[0][i])) + mpmath.mpf(float(d[1][i]))
        p, e = _dd.two_prod(a, b)
        s, t = _dd.two_sum(a, b)
        q = _dd.dd_div_d(_dd.dd(a), b)
        prod = _dd.dd_mul(q, _dd.dd(b))
        for i in range(a.size):
            ai, bi = mpmath.mpf(float(a[i])), mpmath.mpf(float(b[i]))
            assert mpmath.mpf(float(p[i])) + float(e[i]) == ai * bi
            assert mpmath.mpf(float(s[i])) + float(t[i]) == ai + bi
            assert abs(val(q, i) - ai / bi) <= 1e-31 * abs(ai / bi)
            assert abs(val(prod, i) - ai) <= 1e-31 * abs(ai)
        terms = _dd.dd_mul(_dd.dd(a), _dd.dd(b))
        total = _dd.dd_sum(terms)
        exact = mpmath.fsum(mpmath.mpf(float(a[i])) * float(b[i]) for i in range(a.size))
        bound = 1e-30 * sum(abs(a * b))
        assert abs(mpmath.mpf(float(total[0])) + float(total[1]) - exact) <= bound
        dot = _dd.dd_dot(_dd.dd(a.reshape(20, 10)), _dd.dd(b.reshape(20, 10)), axis=1)
        for r in range(20):
            ex = mpmath.fsum(mpmath.mpf(float(a[10 * r + j])) * float(b[10 * r + j])
                             for j in range(10))
            got = mpmath.mpf(float(dot[0][r])) + float(dot[1][r])
            assert abs(got - ex) <= 1e-30 * sum(abs(a[10 * r:10 * r + 10] * b[10 * r:10 * r + 10]))


# --------------------------------------------------------------------------
# error convention, statistically
# --------------------------------------------------------------------------
N_REPLICATES = 2000


@pytest.mark.slow
def test_coverage_with_given_sigma():
    # heteroscedastic noise with its sigma given: absolute errors must cover
    rng = np.random.default_rng(2718)
    x = np.linspace(-1.0, 2.0, 30)
    truth = np.array([0.5, -1.0, 0.8, 0.3])
    y_true = np.polynomial.polynomial.polyval(x, truth)
    sigma = 0.05 * (1 + x ** 2)
    hits, red = np.zeros(4), []
    for _ in range(N_REPLICATES):
        res = polyfit(x, y_true + sigma * rng.standard_normal(x.size), range(4), sigma=sigma)
        hits += np.abs(res.coefficients - truth) < res.stderr
        red.append(res.reduced_chi2)
    np.testing.assert_allclose(hits / N_REPLICATES, 0.683, atol=0.03)
    assert np.mean(red) == pytest.approx(1.0, abs=0.03)


@pytest.mark.slow
def test_coverage_with_sigma_from_residuals():
    # homoscedastic noise, sigma unknown: |c - truth| / stderr follows Student t(dof)
    rng = np.random.default_rng(31415)
    x = np.linspace(-1.0, 2.0, 30)
    truth = np.array([0.5, -1.0, 0.8, 0.3])
    y_true = np.polynomial.polynomial.polyval(x, truth)
    tq = stats.t.ppf(0.8413, x.size - 4)
    hits = np.zeros(4)
    for _ in range(N_REPLICATES):
        res = polyfit(x, y_true + 0.2 * rng.standard_normal(x.size), range(4))
        hits += np.abs(res.coefficients - truth) / res.stderr < tq
    np.testing.assert_allclose(hits / N_REPLICATES, 0.683, atol=0.03)
