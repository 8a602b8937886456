"""Replicates of a proposed recording: simulated under the truth (its parameters drawn
from their covariance, noise), both hypotheses refitted, the separation achieved.

The synthetic problems are linear and Gaussian, where the separation's distribution is
known exactly; the proposal's use of the replicates runs on a stub gate model.
"""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.stats import ncx2

import dpdfit.analyses.diagnosis.proposal.next_measurement as next_measurement
from dpdfit.analyses.diagnosis.evidence.thresholds import BIC_DECISIVE
from dpdfit.analyses.diagnosis.model.parameters import Parameter, Parameters
from dpdfit.analyses.diagnosis.proposal.expected_separation import Direction
from dpdfit.analyses.diagnosis.proposal.next_measurement import (decisive_target,
                                                                 decisive_threshold,
                                                                 propose_next_measurement)
from dpdfit.analyses.diagnosis.proposal.replicates import (REPLICATES, replicate_separations,
                                                           summary)
from tests.analyses.diagnosis.proposal.test_next_measurement import _fit, _StubGate


class _Linear:
    """A hypothesis predicting ``f(p)`` (shared with its rival), at its fit ``p``, whose
    parameters ``keys`` absorb a recording, with covariance ``C``."""

    def __init__(self, f, p, keys, C, label):
        self.f, self.p, self.keys, self.C, self.label = f, dict(p), list(keys), C, label

    def absorbing(self, source):
        return [(k, 1e-3) for k in self.keys]

    def covariance(self, keys):
        return None if self.C is None else np.asarray(self.C, float)


def _item(what="linear"):
    return SimpleNamespace(what=what, settings={}, source="gates", pooled=None,
                           vector=lambda h, p=None: h.f(h.p if p is None else p))


def _nested(n=15, k=3, seed=5):
    """Two parameters ``(a, s)``, predictions linear in them; the recordings so far carry
    the information ``G`` about them.  The truth has both free, fitted at ``(a, s)``; the
    rival holds ``s = 0``, its ``a`` fitted to the same recordings (one parameter
    absorbing, information ``G_aa``)."""
    rng = np.random.default_rng(seed)
    J = rng.normal(size=(n, 2))
    m0 = rng.normal(size=n)
    sd = rng.uniform(0.5, 1.5, n)

    def f(p):
        return m0 + J @ np.array([p["a"], p["s"]])
    G = np.array([[4.0, 1.5], [1.5, 8.0]])
    a_hat, s_hat = 0.3, 0.9
    truth = _Linear(f, {"a": a_hat, "s": s_hat}, ["a", "s"], np.linalg.inv(G), "truth")
    # the rival's own fit to the recordings so far: a moved to absorb what s did
    rival = _Linear(f, {"a": a_hat + G[0, 1] / G[0, 0] * s_hat, "s": 0.0}, ["a"],
                    [[1 / G[0, 0]]], "rival")
    W = 1.0 / sd
    Jk = np.sqrt(k) * W[:, None] * J
    return truth, rival, W, G, Jk.T @ Jk, s_hat


def test_replicates_follow_the_exact_distribution_of_the_separation():
    """Nested linear-Gaussian hypotheses: with the truth's parameters drawn from their
    posterior ``N(fit, G^-1)`` and both refitted with the recordings so far as their
    information, the separation achieved is ``chi2_rival - chi2_truth = c X - s^2/v``,
    ``X ~ ncx2(1, s^2 / (v - v'))``, ``c = (v - v') / v'``, ``v`` and ``v'`` the variance
    of ``s`` before and after the recording (the likelihood-ratio statistic for ``s = 0``
    on all recordings less the one on the recordings so far).  The replicates' median
    and 10th percentile agree with it within their Monte Carlo error; the linearised
    figure is the Asimov value ``s^2/v' - s^2/v``."""
    k = 3
    truth, rival, W, G, H, s_hat = _nested(k=k)
    d = Direction(_item(), truth, rival, W, profile=True)
    v, v_after = np.linalg.inv(G)[1, 1], np.linalg.inv(G + H)[1, 1]
    c, nc, shift = (v - v_after) / v_after, s_hat ** 2 / (v - v_after), s_hat ** 2 / v
    assert d.linearised(k)[0] == pytest.approx(s_hat ** 2 / v_after - shift, rel=1e-6)
    R = 1500
    s = replicate_separations(d, k, n=R, seed=7)
    assert s.shape == (R,) and np.all(np.isfinite(s))
    for q in (0.1, 0.5):
        want = c * ncx2.ppf(q, 1, nc) - shift
        # the sample quantile's standard error, sqrt(q (1 - q) / R) / density
        density = ncx2.pdf((want + shift) / c, 1, nc) / c
        se = np.sqrt(q * (1 - q) / R) / density
        assert np.quantile(s, q) == pytest.approx(want, abs=4 * se)
    # and the spread is the drawn parameters' and the noise's, not zero
    assert np.std(s) == pytest.approx(np.sqrt(c * c * 2 * (1 + 2 * nc)), rel=0.15)


def test_replicates_are_reproducible_and_the_default_seed_follows_the_item():
    truth, rival, W, *_ = _nested()
    d = Direction(_item(), truth, rival, W, profile=True)
    a, b = replicate_separations(d, 2), replicate_separations(d, 2)
    assert a.shape == (REPLICATES,) and np.array_equal(a, b)
    other = Direction(_item("another"), truth, rival, W, profile=True)
    assert not np.array_equal(a, replicate_separations(other, 2))
    assert summary(a) == {"median": pytest.approx(np.median(a)),
                          "p10": pytest.approx(np.percentile(a, 10)), "n": REPLICATES}


def test_no_covariance_no_replicates():
    truth, rival, W, *_ = _nested()
    held = _Linear(rival.f, rival.p, rival.keys, None, "rival")
    assert replicate_separations(Direction(_item(), truth, held, W, True), 2) is None
    assert summary([np.nan, np.nan, 1.0]) is None


def test_a_rival_absorbing_noise_keeps_the_10th_percentile_short_of_the_expected_figure():
    """A fixed truth; a rival with ten parameters whose predictions are orthogonal to the
    difference, no information on them from the recordings so far to speak of: nothing of
    the difference is absorbed, so the linearised separation is the held one, 30, above
    the target; but each replicate's refit absorbs ten dimensions of noise, and the 10th
    percentile (about 30 - 10 - 1.28 * 2 sqrt(30)) does not decide."""
    n, q = 60, 10
    rng = np.random.default_rng(3)
    d_vec = np.zeros(n)
    d_vec[0] = np.sqrt(30.0)
    X = np.zeros((n, q))
    X[1:1 + q, :] = rng.normal(size=(q, q))             # orthogonal to the difference
    truth = _Linear(lambda p: d_vec, {}, [], None, "truth")
    rival = _Linear(lambda p: X @ np.array([p[f"t{i}"] for i in range(q)]),
                    {f"t{i}": 0.0 for i in range(q)}, [f"t{i}" for i in range(q)],
                    1e6 * np.eye(q), "rival")
    d = Direction(_item(), truth, rival, np.ones(n), profile=True)
    assert d.linearised(1)[0] == pytest.approx(30.0, rel=1e-6)
    assert d.linearised(1)[0] > decisive_target()
    R = 400
    s = replicate_separations(d, 1, n=R, seed=2)
    # 30 + 2 sqrt(30) Z - chi2(10): mean 20, sd sqrt(120 + 20)
    assert np.mean(s) == pytest.approx(30.0 - q, abs=4 * np.sqrt(140.0 / R))
    assert summary(s)["p10"] < decisive_threshold()


# ----------------------------------------------------------------- in the proposal
def _dephasing(x: float, sd: float):
    """The dephasing hypothesis of the stub gate, its size ``x`` fitted with error ``sd``."""
    f = _fit("dephasing", {"dephasing.x": x})
    return dataclasses.replace(
        f, parameters=Parameters((Parameter("dephasing.x", x, -1.0, 1.0, 0.01,
                                            error=sd),)), cov=np.array([[sd * sd]]))


def _stub_prob():
    return SimpleNamespace(tone=None, tone_noise=None, gate=_StubGate(), ts=None,
                           runs_after=None, camp=SimpleNamespace(has_imbalance=True))


def test_the_proposal_reports_its_replicates_and_a_decisive_one_decides_in_them():
    """Fits with a covariance: the chosen recording is simulated under each hypothesis of
    its binding pair; it is decisive, and so in 9 of 10 of the simulated recordings."""
    prob = _stub_prob()
    hyps = [_fit("spam_offset"), _dephasing(0.02, 0.002)]
    nm = propose_next_measurement(prob, hyps)
    r = nm.to_dict()["replicates"]
    assert r["basis"] == "replicates" and r["needed"] == BIC_DECISIVE
    assert set(r) == {"basis", "needed", "truth", "rival"}
    for side in ("truth", "rival"):
        assert set(r[side]) == {"median", "p10", "n"} and r[side]["n"] == REPLICATES
        assert r[side]["p10"] <= r[side]["median"]
    assert nm.decisive and min(r["truth"]["p10"], r["rival"]["p10"]) >= BIC_DECISIVE
    assert "in 9 of 10 simulated recordings" in nm.sentence()
    from dpdfit.analyses.diagnosis.rendering import next_measurement_sentence
    low = min(r["truth"]["p10"], r["rival"]["p10"])
    assert f"(at least {low:.0f} in 9 of 10 simulated recordings)" in \
        next_measurement_sentence(nm.to_dict())
    # reproducible, and read back from its JSON
    again = propose_next_measurement(prob, hyps)
    assert again.replicates == nm.replicates
    assert next_measurement.NextMeasurement.from_dict(nm.to_dict()).replicates == nm.replicates


def test_an_expected_figure_above_the_target_with_a_short_10th_percentile_is_not_decisive(
        monkeypatch):
    """The linearised (and refitted) figure exceeds the target, the replicates' 10th
    percentile does not reach BIC_DECISIVE: the proposal is not decisive and says why."""
    prob = _stub_prob()
    hyps = [_fit("spam_offset"), _dephasing(0.02, 0.002)]
    assert propose_next_measurement(prob, hyps).decisive
    calls = []

    def short(direction, k, n=REPLICATES, seed=None):
        calls.append(k)
        return np.linspace(2.0, 60.0, n)                 # median 31, p10 about 7.8
    monkeypatch.setattr(next_measurement, "replicate_separations", short)
    nm = propose_next_measurement(prob, hyps)
    assert nm.expected_delta_bic >= decisive_target()
    assert len(calls) == 2                               # the binding pair, both ways
    assert nm.decisive is False and nm.to_dict()["decisive"] is False
    assert "1 in 10 of its simulated recordings" in nm.reason
    assert "short of the 10 that decides" in nm.reason
    p10 = summary(np.linspace(2.0, 60.0, REPLICATES))["p10"]
    assert p10 < BIC_DECISIVE and nm.replicates["truth"]["p10"] == pytest.approx(p10)


def test_held_parameters_fall_back_to_the_expected_figure():
    prob = _stub_prob()
    nm = propose_next_measurement(prob, [_fit("spam_offset"), _dephasing(0.02, 0.002)],
                                  profile=False)
    assert nm.replicates["basis"] == "expected_delta_bic" and "held" in nm.replicates["why"]
    assert nm.decisive is (nm.expected_delta_bic >= decisive_target())
