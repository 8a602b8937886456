"""ramsey.csv fitted as data: the effects' free-precession dephasing and the gate model's
SPAM predict it, the coherence time it records is reported beside the lab's stated T2;
a campaign without it is diagnosed as before."""

import dataclasses
import shutil

import numpy as np
import pytest

from dpdfit.analyses.diagnosis.fitting.hypothesis_fit import fit_hypothesis
from dpdfit.analyses.diagnosis.model.ramsey_block import (T2_REC, ramsey_block,
                                                          ramsey_probabilities_of)
from dpdfit.analyses.diagnosis.model.residuals import Problem
from dpdfit.analyses.diagnosis.observables.campaign import load_campaign
from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.models.ramsey import ramsey_probabilities
from dpdfit.simulation.campaign import simulate_campaign
from dpdfit.simulation.campaign.ramsey_runs import ramsey_dephasing, ramsey_waits
from tests.helpers.further_campaign import small_config

RATE = 60.0


def _simulated(tmp_path_factory, name, effects):
    cfg = dataclasses.replace(small_config(), ramsey_shots=200).inject(effects)
    out = tmp_path_factory.mktemp(name) / "c"
    simulate_campaign(out, seed=cfg.seed, config=cfg, progress=False)
    plain = out.parent / "plain"
    shutil.copytree(out, plain)
    (plain / "ramsey.csv").unlink()
    return cfg, Problem(load_campaign(out)), Problem(load_campaign(plain))


@pytest.fixture(scope="module")
def common_case(tmp_path_factory):
    """A small campaign with common-mode white dephasing: with and without ramsey.csv."""
    return _simulated(tmp_path_factory, "common", {"dephasing": {"rate": RATE, "f_cm": 1.0}})


def test_without_the_table_nothing_changes(common_case):
    _, with_r, plain = common_case
    assert plain.camp.ramsey is None and T2_REC not in plain.prior
    assert "ramsey" not in [lab["kind"] for lab, _ in plain.blocks({})]
    assert "coherence" not in plain.null_model().to_dict()
    # the gate model's knobs are the effects' own
    knobs = {k.key for e in plain.gate.effects for k in EFFECTS[e].knobs()}
    assert set(plain.gate.knobs) == knobs
    # with it: a block and the report, no nuisance (the stated T2 stays the baseline's)
    assert T2_REC not in with_r.prior
    assert "ramsey" in [lab["kind"] for lab, _ in with_r.blocks({})]
    assert with_r.null_model().to_dict()["coherence"]["T2_stated_ms"] == pytest.approx(50.0)


def test_model_and_simulator_agree(common_case):
    """The diagnosis predicts the simulator's physics: the recorded T2 white and
    independent, dephasing's common, slow and stretched parts, the echo removing the slow."""
    cfg, prob, _ = common_case
    gm = prob.gate
    t = ramsey_waits(cfg.T2)
    for v in ({"rate": RATE, "f_cm": 1.0, "beta": 1.0, "during": 1.0},
              {"rate": RATE, "f_cm": 0.4, "beta": 2.0, "during": 1.0},
              {"rate": RATE, "f_cm": 0.3, "beta": 1.7, "during": 0.0}):
        sim_cfg = small_config().inject({"dephasing": v})
        p = {T2_REC: cfg.T2 * 1e3, "prep_split": 1.0, "e01": cfg.p_det, "e10": cfg.p_det,
             **{f"dephasing.{k}": x for k, x in v.items()}}
        active = [(EFFECTS["dephasing"], v)]
        for echo in (False, True):
            want = ramsey_probabilities(*ramsey_dephasing(sim_cfg, {"t_ref": gm.t_ref}, t, echo),
                                        cfg.p_prep, 0.0, cfg.p_det, cfg.p_det)
            got = ramsey_probabilities_of(gm, p, active, t, echo)
            assert np.allclose(got, want, rtol=0, atol=1e-12), (v, echo)


def test_what_changes_the_prediction(common_case):
    _, prob, _ = common_case
    base = {"prep_split": 0.5, "e01": 5e-5, "e10": 5e-5, T2_REC: 50.0}
    _, z0 = ramsey_block(prob, base)
    assert np.array_equal(ramsey_block(prob, {**base, "motional_heating.ndot": 1.0})[1], z0)
    for k, v in (("dephasing.rate", 100.0), ("spam_offset.p_extra", 0.01), (T2_REC, 20.0)):
        if k.startswith("dephasing"):
            v = {k: v, "dephasing.f_cm": 1.0}
        else:
            v = {k: v}
        assert not np.allclose(ramsey_block(prob, {**base, **v})[1], z0), k


def test_ramsey_tightens_the_fitted_rate(common_case):
    """With ramsey.csv the common-mode rate is measured in free precession too: within 3
    sigma of the truth, its error well below the gates' alone; the baseline's recorded
    T2 is reported."""
    _, with_r, plain = common_case
    hyp = (("dephasing", "common"),)
    sizes = []
    for prob in (plain, with_r):
        base = fit_hypothesis(prob, ())
        tone = {k: v for k, v in base.nuisances.items() if prob.is_tone_key(k)}
        sizes.append(fit_hypothesis(prob, hyp, fixed=tone).sizes["dephasing"]["rate_per_s"])
    alone, joint = sizes
    assert abs(joint.value - RATE) < 3 * joint.error
    assert joint.error < 0.6 * alone.error


def test_recorded_t2_is_reported_and_the_dephasing_named_from_it(tmp_path_factory):
    """White independent dephasing in free precession is a T2 shorter than stated: the
    recording's own T2 is reported (the truth within 3 sigma) beside the stated 50 ms, and
    the catalog's independent dephasing fitted with the table finds its rate."""
    cfg, prob, _ = _simulated(tmp_path_factory, "independent",
                              {"dephasing": {"rate": 80.0, "f_cm": 0.0}})
    base = fit_hypothesis(prob, ())
    coh = prob.null_model(base).to_dict()["coherence"]
    truth = 1e3 / (1 / cfg.T2 + 80.0)
    assert coh["T2_stated_ms"] == pytest.approx(50.0)
    assert abs(coh["T2_recorded_ms"] - truth) < 3 * coh["T2_recorded_err_ms"]
    assert coh["T2_recorded_err_ms"] < 0.1 * truth
    tone = {k: v for k, v in base.nuisances.items() if prob.is_tone_key(k)}
    rate = fit_hypothesis(prob, (("dephasing", "independent"),),
                          fixed=tone).sizes["dephasing"]["rate_per_s"]
    assert abs(rate.value - 80.0) < 3 * rate.error and rate.error < 20.0
