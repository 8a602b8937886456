"""thermometry.csv fitted as data: predicted from the gate model's motional state through
the effects' knobs, so it constrains heating and not dephasing."""

import dataclasses

import numpy as np
import pandas as pd
import pytest

from dpdfit.analyses.diagnosis.fitting.hypothesis_fit import fit_hypothesis
from dpdfit.analyses.diagnosis.model.residuals import Problem
from dpdfit.analyses.diagnosis.model.thermometry_block import (motional_state,
                                                               thermometry_block,
                                                               thermometry_probabilities)
from dpdfit.analyses.diagnosis.observables.campaign import load_campaign
from dpdfit.simulation.campaign import simulate_campaign
from dpdfit.simulation.campaign.thermometry_runs import thermometry_engine, thermometry_rows
from tests.helpers.further_campaign import small_config

#: injected extra heating (quanta/ms)
NDOT = 0.1


@pytest.fixture(scope="module")
def heating_case(tmp_path_factory):
    """A small campaign with extra heating (no thermometry.csv), its config and problem."""
    cfg = small_config().inject({"motional_heating": {"ndot": NDOT}})
    out = tmp_path_factory.mktemp("thermo") / "c"
    simulate_campaign(out, seed=cfg.seed, config=cfg, progress=False)
    return cfg, Problem(load_campaign(out))


def _with_thermometry(prob, rows):
    """A shallow copy of the fixture's problem whose campaign has ``rows`` as its
    thermometry.csv (the models and nuisances shared: only the data block differs)."""
    th = pd.DataFrame(rows)
    th["wait_s"] = th["wait_us"] * 1e-6
    out = object.__new__(Problem)
    out.__dict__.update(prob.__dict__)
    out.camp = dataclasses.replace(prob.camp, thermometry=th)
    return out


def test_model_and_simulator_agree(heating_case):
    """The diagnosis's motional state is the simulator's after the injection, and its
    prediction the simulator's probabilities."""
    cfg, prob = heating_case
    base = {"prep_split": 1.0, "e01": cfg.p_det, "e10": cfg.p_det}
    truth = thermometry_engine(cfg)
    nbar, ndot = motional_state(prob.gate, {**base, "motional_heating.ndot": NDOT})
    assert (nbar, ndot) == pytest.approx((truth["nbar"], truth["ndot"]), rel=1e-12)
    assert motional_state(prob.gate, base) == pytest.approx((cfg.nbar, cfg.ndot))
    wait = np.array([0.0, 5e-3])
    got = thermometry_probabilities(prob.gate, {**base, "motional_heating.ndot": NDOT}, wait,
                                    ["red", "blue"])
    from dpdfit.models.sideband_thermometry import bright_probability, mean_occupation
    want = bright_probability(mean_occupation(truth["nbar"], truth["ndot"], wait),
                              np.array(["red", "blue"]), truth["p_prep"], 0.0,
                              truth["e01"], truth["e10"])
    assert np.allclose(got, want, rtol=1e-12)


def test_heating_constrained_dephasing_not(heating_case):
    cfg, prob = heating_case
    prob = _with_thermometry(prob, thermometry_rows(cfg, 200, np.random.default_rng(0)))
    base = {"prep_split": 0.5, "e01": 5e-5, "e10": 5e-5}
    _, z0 = thermometry_block(prob, base)
    assert np.array_equal(thermometry_block(prob, {**base, "dephasing.rate": 100.0})[1], z0)
    _, z1 = thermometry_block(prob, {**base, "motional_heating.ndot": NDOT})
    assert np.sum(z1 ** 2) < np.sum(z0 ** 2) - 20
    assert "thermometry" in [lab["kind"] for lab, _ in prob.blocks(base)]


def test_campaign_without_it_is_fitted_as_before(heating_case):
    """No thermometry: no block; with it, one block more and every other block as it was."""
    cfg, prob = heating_case
    assert prob.camp.thermometry is None
    p = {"prep_split": 0.5, "e01": 5e-5, "e10": 5e-5, "motional_heating.ndot": NDOT}
    without = prob.blocks(p)
    assert "thermometry" not in [lab["kind"] for lab, _ in without]
    withit = _with_thermometry(prob, thermometry_rows(cfg, 200, np.random.default_rng(0)))
    others = [(lab, z) for lab, z in withit.blocks(p) if lab["kind"] != "thermometry"]
    assert len(others) == len(without) == len(withit.blocks(p)) - 1
    for (la, za), (lb, zb) in zip(without, others):
        assert la == lb and np.array_equal(za, zb, equal_nan=True)


def test_thermometry_tightens_the_fitted_heating_rate(heating_case):
    """Over a few thermometry draws (8 waits x 2 sidebands x 200 shots): the fitted heating
    rate is within 3 sigma of the truth, and its error is smaller than the gates' alone."""
    cfg, prob = heating_case
    base = fit_hypothesis(prob, ())
    tone = {k: v for k, v in base.nuisances.items() if prob.is_tone_key(k)}
    hyp = (("motional_heating", "during"),)
    alone = fit_hypothesis(prob, hyp, fixed=tone).sizes["motional_heating"]["heating_q_per_ms"]
    true_rate = thermometry_engine(cfg)["ndot"] / 1e3
    for seed in range(3):
        th = _with_thermometry(prob, thermometry_rows(cfg, 200, np.random.default_rng(seed)))
        size = fit_hypothesis(th, hyp, fixed=tone).sizes["motional_heating"]["heating_q_per_ms"]
        assert abs(size.value - true_rate) < 3 * size.error
        assert size.error < 0.8 * alone.error


def test_recorded_motion_is_reported_and_the_heating_named_from_it(heating_case, tmp_path):
    """With thermometry.csv in the folder: the null model reports the nbar and heating rate
    the recording measures on its own, with errors, beside the stated ones; the baseline
    keeps the stated state (no nuisance replaces it), so the heating effect takes up what
    the recording shows, measured far better than by the gates alone and decisively better
    than the baseline.  Without it nothing is reported."""
    import shutil
    from dpdfit.analyses.diagnosis.effects import EFFECTS
    from dpdfit.recordings.campaign_folder import CampaignFolder
    cfg, prob = heating_case
    assert prob.null_model().to_dict().get("recorded_motion") is None
    folder = tmp_path / "c"
    shutil.copytree(CampaignFolder(prob.camp.folder).path, folder)
    pd.DataFrame(thermometry_rows(cfg, 200, np.random.default_rng(0))).to_csv(
        folder / "thermometry.csv", index=False)
    withit = Problem(load_campaign(folder))
    assert not {"thermo_dnbar", "thermo_dndot"} & set(withit.prior)
    assert all(not f.replaces for f in EFFECTS["motional_heating"].forms_for(withit))
    base = fit_hypothesis(withit, ())
    rec = withit.null_model(base).to_dict()["recorded_motion"]
    true_rate = thermometry_engine(cfg)["ndot"] / 1e3
    heat = rec["heating_q_per_ms"]
    assert heat["stated"] == pytest.approx(cfg.ndot / 1e3)
    assert 0 < heat["error"] < 0.02 and abs(heat["recorded"] - true_rate) < 3 * heat["error"]
    assert rec["nbar"]["stated"] == pytest.approx(cfg.nbar) and rec["nbar"]["error"] > 0
    from dpdfit.analyses.diagnosis.rendering import _null_model_lines
    text = "\n".join(_null_model_lines(withit.null_model(base).to_dict()))
    assert f"recorded heating rate (quanta/ms) {heat['recorded']:.3g}" in text
    assert "recorded heating" not in "\n".join(_null_model_lines(prob.null_model(
        fit_hypothesis(prob, ())).to_dict()))
    tone = {k: v for k, v in base.nuisances.items() if withit.is_tone_key(k)}
    hyp = (("motional_heating", "during"),)
    fit = fit_hypothesis(withit, hyp, fixed=tone)
    size = fit.sizes["motional_heating"]["heating_q_per_ms"]
    assert size.error < 1.5 * heat["error"] and abs(size.value - true_rate) < 3 * size.error
    assert fit.n_par == base.n_par + 1 and base.chi2 - fit.chi2 > 25.0
    alone = fit_hypothesis(prob, hyp, fixed={k: v for k, v in fit_hypothesis(
        prob, ()).nuisances.items() if prob.is_tone_key(k)})
    assert size.error < 0.5 * alone.sizes["motional_heating"]["heating_q_per_ms"].error
