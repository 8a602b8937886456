"""The tempering of the evidence between two hypotheses by the misfit they leave, the
alternatives it keeps in reach, and the errors that include the form.

Statistical claims are checked over simulated replicates with fixed seeds: the
dispersion of the evidence stays near 1 for white residuals, and the inflated
error of a fitted slope covers the truth under correlated noise where the naive
error does not.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from dpdfit.analyses.diagnosis.decisions.alternatives import (addition_alternatives,
                                                              swap_alternatives)
from dpdfit.analyses.diagnosis.effects import Size
from dpdfit.analyses.diagnosis.evidence.form_errors import (form_weights, honest_cost,
                                                            honest_sizes)
from dpdfit.analyses.diagnosis.evidence.tempering import (evidence_dispersion,
                                                          hac_quadratic, series_pairs,
                                                          tempered_gap)
from dpdfit.analyses.diagnosis.rendering import alternatives_sentence


def _ar1(rng, n, rho):
    e = np.empty(n)
    e[0] = rng.normal()
    for i in range(1, n):
        e[i] = rho * e[i - 1] + np.sqrt(1 - rho ** 2) * rng.normal()
    return e


def _fit(chi2, n_par, z, n_obs=1000, **kw):
    """A stand-in for a FitResult: what the tempering and the alternatives read."""
    return SimpleNamespace(chi2=chi2, n_par=n_par, n_obs=n_obs,
                           bic=chi2 + n_par * np.log(n_obs),
                           blocks=(("tones:R10", np.asarray(z, dtype=float)),), **kw)


def test_white_residuals_leave_the_evidence_untempered():
    """For white unit residuals tau scatters about 1 on one series and stays at 1 to
    within a few per cent over the ~20 series of a campaign's spectra."""
    rng = np.random.default_rng(11)
    x = np.linspace(0, 1, 100)
    d = 0.3 * np.sin(3 * x) + 0.1
    one = np.array([max(1.0, np.divide(*hac_quadratic(d, rng.normal(size=x.size))))
                    for _ in range(1000)])
    assert one.mean() < 1.2 and np.mean(one > 2) < 0.03
    many = []
    for _ in range(200):
        q = dd = 0.0
        for _ in range(20):
            a, b = hac_quadratic(d, rng.normal(size=x.size))
            q, dd = q + a, dd + b
        many.append(max(1.0, q / dd))
    many = np.array(many)
    assert many.mean() < 1.06 and np.mean(many > 1.2) < 0.03


@pytest.mark.parametrize("rho, naive_max, cov1_min, cov2_min", [(0.5, 0.45, 0.57, 0.88),
                                                                 (0.7, 0.38, 0.53, 0.85)])
def test_inflated_slope_error_covers_under_correlated_noise(rho, naive_max, cov1_min,
                                                            cov2_min):
    """A line fitted to data with AR(1) noise: the naive error under-covers; times
    sqrt(tau) (tau along the slope's own direction) it covers nearly as it should."""
    rng = np.random.default_rng(2611)
    n, truth = 100, 0.3
    x = np.linspace(-1, 1, n)
    J = np.c_[np.ones(n), x]
    se = np.sqrt(np.linalg.inv(J.T @ J)[1, 1])
    naive, cov1, cov2 = [], [], []
    for _ in range(600):
        y = truth * x + _ar1(rng, n, rho)
        beta = np.linalg.lstsq(J, y, rcond=None)[0]
        q, dd = hac_quadratic(beta[1] * x, y - J @ beta)
        pull = (beta[1] - truth) / se
        tau = max(1.0, q / dd)
        naive.append(abs(pull) <= 1)
        cov1.append(abs(pull) / np.sqrt(tau) <= 1)
        cov2.append(abs(pull) / np.sqrt(tau) <= 2)
    assert np.mean(naive) < naive_max
    assert np.mean(cov1) > cov1_min
    assert np.mean(cov2) > cov2_min


def test_tone_blocks_split_into_series_along_the_amplitude():
    a = np.arange(24.0).reshape(6, 2, 2)
    pairs = list(series_pairs(a, a + 1))
    assert len(pairs) == 4 and all(p[0].shape == (6,) for p in pairs)
    assert list(series_pairs(np.zeros(3), np.zeros(4))) == []


def test_a_gap_made_of_correlated_misfit_is_not_decisive():
    """Two forms 40 apart in chi2 whose difference follows a smooth misfit that both
    leave (reduced chi2 ~1.5): raw delta BIC 40, tempered far below 10."""
    rng = np.random.default_rng(3)
    n = 400
    x = np.linspace(0, 1, n)
    misfit = 0.7 * np.cos(2 * np.pi * x)
    e_best = misfit + rng.normal(size=n)
    d = 0.2 * np.cos(2 * np.pi * x)                 # the other form follows it less well
    e_other = e_best + d
    best = _fit(float(e_best @ e_best), 3, e_best)
    other = _fit(float(best.chi2 + 40.0), 3, e_other)
    raw, gap_t, tau = tempered_gap(other, best)
    assert raw == pytest.approx(40.0)
    assert tau > 4 and gap_t < 10


def test_a_gap_with_white_residuals_stays_decisive():
    rng = np.random.default_rng(4)
    n = 400
    e_best = rng.normal(size=n)
    d = 0.5 * np.sin(np.linspace(0, 3, n))
    other_z = e_best + d
    best = _fit(float(e_best @ e_best), 3, e_best)
    other = _fit(float(other_z @ other_z), 3, other_z)
    raw, gap_t, tau = tempered_gap(other, best)
    assert tau < 1.6 and gap_t > 10 and raw > gap_t - 1e-9
    assert evidence_dispersion(best, best) == 1.0


def _entry(effect, dbic, dbic_t, p=1e-12, side="tones", tau=1.0, dchi2=None):
    return {"effect": effect, "delta_bic": dbic, "delta_bic_tempered": dbic_t,
            "p_value": p, "p_value_tempered": p, "side": side, "tempering": tau,
            "delta_chi2": -dbic if dchi2 is None else dchi2}


def test_swap_alternatives_keep_the_candidates_in_reach():
    rng = np.random.default_rng(5)
    n = 400
    x = np.linspace(0, 1, n)
    e = 0.7 * np.cos(2 * np.pi * x) + rng.normal(size=n)
    fa = _fit(float(e @ e), 5, e, effects=("a",), forms=("f",))
    zb = e + 0.2 * np.cos(2 * np.pi * x)
    fb = _fit(fa.chi2 + 30.0, 5, zb, effects=("b",), forms=("f",))
    zc = e + 3.0 * np.sin(2 * np.pi * x)
    fc = _fit(float(zc @ zc), 5, zc, effects=("c",), forms=("f",))
    ranking = [_entry("a", -500, -200), _entry("b", -470, -190), _entry("c", -50, -5)]
    alts = swap_alternatives({"a": fa, "b": fb, "c": fc}, {}, ranking, "a", ["a"], None)
    assert [a["effect"] for a, _ in alts] == ["b"]      # c is not decisive on its own
    a = alts[0][0]
    assert a["delta_bic"] == pytest.approx(30.0) and a["delta_bic_tempered"] < 10
    assert a["named"] == ["b"] and a["replaces"] == "a"
    words = alternatives_sentence("a", [a])
    assert words == ["a, or b: these recordings do not separate them"]


def test_additions_decisive_only_before_tempering_are_alternatives():
    """In reach: the raw likelihood would add it, and its chi2 gain divided by the
    dispersion of the evidence is still decisive (>= 10), whatever its parameters cost."""
    f_add = SimpleNamespace(effects=("a", "c"))
    f_far = SimpleNamespace(effects=("a", "d"))
    f_weak = SimpleNamespace(effects=("a", "e"))
    steps = [([(_entry("a+c", -40, -7, tau=3.0, dchi2=46.0), f_add),
               (_entry("a+d", -40, 12, tau=10.0, dchi2=46.0), f_far),
               (_entry("a+e", -40, -3, tau=5.0, dchi2=46.0), f_weak)], None)]
    alts = addition_alternatives(steps, ["a"])
    assert [(a["effect"], a["named"], a["replaces"]) for a, _ in alts] == [("c", ["a", "c"],
                                                                            None)]
    assert "perhaps also c" in alternatives_sentence("a", [a for a, _ in alts])[0]


def test_form_spread_and_misfit_enter_the_error():
    def form_fit(chi2, value):
        z = np.random.default_rng(int(chi2)).normal(size=50)
        f = _fit(chi2, 2, z)
        f.sizes = {"e": {"s": Size("s", value, 0.01, "1")}}
        return f
    forms = {"catalog": form_fit(100.0, 1.0), "other": form_fit(101.0, 1.2),
             "far": form_fit(400.0, 5.0)}
    w = form_weights(forms)
    assert sum(w.values()) == pytest.approx(1.0) and w["far"] < 1e-6
    out = honest_sizes({"s": Size("s", 1.0, 0.01, "1")}, "e", "catalog", forms, tau=4.0)
    s = out["s"]
    assert s["error_statistical"] == 0.01 and s["tempering"] == 4.0
    assert 0.05 < s["error_form"] < 0.2
    assert s["error"] == pytest.approx(np.hypot(0.02, s["error_form"]))
    single = honest_sizes({"s": Size("s", 1.0, 0.01, "1")}, "e", "catalog",
                          {"catalog": forms["catalog"]}, tau=1.0)
    assert single["s"]["error"] == pytest.approx(0.01) and single["s"]["error_form"] == 0
    c, err, spread = honest_cost((0.002, 1e-4), {"catalog": 0.002, "other": 0.003},
                                 "catalog", forms, 1.0)
    assert c == 0.002 and spread > 0 and err > 1e-4


@pytest.mark.parametrize("k_true, q", [(-0.1, 1.0), (0.08, 1.0), (-0.06, 1.5), (0.12, 0.7)])
def test_detector_size_is_the_reading_error_at_full_power(k_true, q):
    """The fitted k is relative to the curve's largest reading; the size is the reading
    error at the largest true power: a detector reading P (1 + k_true (P/P_full)^q) has
    k = k_true (1 + k_true)^q in reading units, and its size is k_true."""
    from dpdfit.analyses.diagnosis.effects import EFFECTS
    k_read = k_true * (1 + k_true) ** q
    size = EFFECTS["detector_nonlinearity"].size_values(
        None, {"detector_nonlinearity.k": k_read, "detector_nonlinearity.q": q})
    assert size["k_det"][0] == pytest.approx(k_true, rel=1e-6)


def test_the_report_says_what_would_decide_or_why_nothing_can():
    from dpdfit.analyses.diagnosis.rendering import next_measurement_sentence
    none = next_measurement_sentence({"what": None, "reason": "no calibration runs to "
                                                              "extend and no gate settings"})
    assert none == ("no further measurement could be proposed: no calibration runs to "
                    "extend and no gate settings")
    one = next_measurement_sentence({"what": "amplitude_run", "settings": {"runs": 1},
                                     "expected_delta_bic": 16.2, "lab_seconds": 300,
                                     "separates": ["stale_calibration",
                                                   "detector_nonlinearity"]})
    assert one.startswith("the measurement that would decide: amplitude run (runs = 1, "
                          "about 5 min of lab time)")
    assert "between stale_calibration and detector_nonlinearity" in one
    assert "\n" not in one
