"""The separation's linear algebra where the information is singular to rounding: a
rival with many parameters, a pair predicting a population at zero."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from dpdfit.analyses.diagnosis.proposal.pooled_scans import scan_whitener
from dpdfit.analyses.diagnosis.proposal.expected_separation import Direction


def test_a_singular_population_covariance_is_whitened_on_what_it_measures():
    # P11 = 0 under both hypotheses: imb = F, so F_pop and imb carry one number
    pr = {"F_pop": np.array([0.9]), "imb": np.array([0.9]), "C": np.array([0.9])}
    for q in ("F_pop", "imb", "C"):
        pr["dlin_" + q] = np.zeros(1)
        pr["dquad_" + q] = np.zeros(1)
    W = scan_whitener(("F_pop", "imb"), 0, 625, 0.0, 0.0)(pr, pr)
    cov = np.array([[0.9 * 0.1, 0.9 * 0.1], [0.9 * 0.1, 0.9 - 0.81]]) / 625
    assert W.shape == (1, 2)
    assert W @ cov @ W.T == pytest.approx(np.eye(1))


def _direction(C):
    """A rival of three parameters, each moving one predicted value by its own amount."""
    truth = SimpleNamespace(p={})
    rival = SimpleNamespace(p={"a": 0.0, "b": 0.0, "c": 0.0},
                            absorbing=lambda source: [("a", 1e-3), ("b", 1e-3), ("c", 1e-3)],
                            covariance=lambda keys: C)

    def vector(h, p=None):
        if h is truth:
            return np.array([1.0, 2.0, 0.5])
        p = h.p if p is None else p
        return np.array([p["a"], 2 * p["b"], p["a"] + p["c"]])
    item = SimpleNamespace(vector=vector, source="gates", pooled=None,
                           whitener=lambda a, b, k=None: None)
    return Direction(item, truth, rival, np.ones(3), profile=True)


def test_the_refit_takes_a_rival_information_semi_definite_to_rounding():
    # a covariance of rank two of three whose null direction came out negative by
    # rounding: its pseudo-inverse's eigenvalue there is -1e9, no information at all
    v = np.array([1.0, -1.0, 0.0]) / np.sqrt(2)
    C = np.eye(3) - (1 + 1e-9) * np.outer(v, v)
    d = _direction(C)
    lin, ref = float(d.linearised(4)[0]), d.refit(4)
    assert np.isfinite(ref) and 0.0 <= ref <= d.fixed(4) + 1e-9
    # the model is linear in the rival's parameters: the refit is the linearised optimum
    assert ref == pytest.approx(lin, rel=1e-6, abs=1e-9)
