"""spam.csv fitted as data: predicted through the gate model's preparation hook, so it
constrains a SPAM offset and not dephasing or heating."""

import dataclasses

import numpy as np
import pandas as pd
import pytest

from dpdfit.analyses.diagnosis.effects import Prep
from dpdfit.analyses.diagnosis.fitting.hypothesis_fit import fit_hypothesis
from dpdfit.analyses.diagnosis.model.residuals import Problem
from dpdfit.analyses.diagnosis.model.spam_block import (deviance_residuals, spam_block,
                                                        spam_probabilities)
from dpdfit.analyses.diagnosis.observables.campaign import load_campaign
from dpdfit.simulation.campaign import simulate_campaign
from dpdfit.simulation.campaign import spam_runs
from tests.helpers.further_campaign import small_config

P_EXTRA = 0.015


@pytest.fixture(scope="module")
def spam_case(tmp_path_factory):
    """A small campaign with a SPAM offset (no spam.csv), its config and its problem."""
    cfg = small_config().inject({"spam_offset": {"p_extra": P_EXTRA}})
    out = tmp_path_factory.mktemp("spam") / "c"
    simulate_campaign(out, seed=cfg.seed, config=cfg, progress=False)
    return cfg, Problem(load_campaign(out))


def test_model_and_simulator_agree():
    """The diagnosis's prediction is the simulator's physics (spectator = p_prep)."""
    got = spam_probabilities(Prep(0.01, 0.002, 1e-3, 2e-3), ["00", "11", "01", "10"])
    want = spam_runs.spam_probabilities(0.01, 0.002, 1e-3, 2e-3, ("00", "11", "01", "10"))
    assert np.allclose(got, want, rtol=1e-12, atol=0)


def test_deviance_residuals_are_the_multinomial_likelihood():
    n = np.array([[990.0, 9.0, 1.0]])
    p = np.array([[0.99, 0.009, 0.001]])
    z = deviance_residuals(n, [1000], p)
    assert np.sum(z ** 2) == pytest.approx(0.0, abs=1e-9)
    q = np.array([[0.995, 0.0049, 0.0001]])
    z = deviance_residuals(n, [1000], q)
    assert np.sum(z ** 2) == pytest.approx(2 * np.sum(n * np.log(n / (1000 * q))))
    assert np.sign(z).tolist() == [[-1.0, 1.0, 1.0]]


def test_spam_offset_constrained_dephasing_and_heating_not(spam_case):
    cfg, prob = spam_case
    spam = pd.DataFrame(spam_runs.spam_rows(cfg, 1000, np.random.default_rng(0)))
    prob = _with_spam(prob, spam)
    base = {"prep_split": 0.5, "e01": 5e-5, "e10": 5e-5}
    _, z0 = spam_block(prob, base)
    for k, v in (("dephasing.rate", 100.0), ("motional_heating.ndot", 1.0)):
        assert np.array_equal(spam_block(prob, {**base, k: v})[1], z0)
    _, z1 = spam_block(prob, {**base, "spam_offset.p_extra": P_EXTRA})
    assert np.sum(z1 ** 2) < np.sum(z0 ** 2) - 20
    labels = [lab["kind"] for lab, _ in prob.blocks(base)]
    assert "spam" in labels


def _with_spam(prob, spam):
    """A shallow copy of the fixture's problem whose campaign has ``spam`` as its
    spam.csv (the models and nuisances shared: only the data block differs)."""
    out = object.__new__(Problem)
    out.__dict__.update(prob.__dict__)
    out.camp = dataclasses.replace(prob.camp, spam=spam)
    return out


def test_spam_table_tightens_the_fitted_offset(spam_case):
    """Over a few SPAM draws: the fitted extra preparation error is within 3 sigma of the
    truth, and its error is smaller than the gates' alone."""
    cfg, prob = spam_case
    assert prob.camp.spam is None
    base = fit_hypothesis(prob, ())
    tone = {k: v for k, v in base.nuisances.items() if prob.is_tone_key(k)}
    hyp = (("spam_offset", "total"),)
    alone = fit_hypothesis(prob, hyp, fixed=tone).sizes["spam_offset"]["extra_preparation"]
    for seed in range(3):
        spam = pd.DataFrame(spam_runs.spam_rows(cfg, 2000, np.random.default_rng(seed)))
        with_spam = _with_spam(prob, spam)
        size = fit_hypothesis(with_spam, hyp, fixed=tone).sizes["spam_offset"][
            "extra_preparation"]
        assert abs(size.value - P_EXTRA) < 3 * size.error
        assert size.error < 0.8 * alone.error
