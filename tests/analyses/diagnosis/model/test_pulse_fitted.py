"""pulse_response.csv fitted as data: predicted through the tone model's drive filters and
power memories, so it constrains the AOM's memory and nothing static."""

import dataclasses

import numpy as np
import pytest

from dpdfit.analyses.diagnosis.fitting.hypothesis_fit import fit_hypothesis
from dpdfit.analyses.diagnosis.model.pulse_block import pulse_block, pulse_prediction
from dpdfit.analyses.diagnosis.model.residuals import Problem
from dpdfit.analyses.diagnosis.observables.campaign import load_campaign, pulse_response_noise
from dpdfit.simulation.campaign import simulate_campaign
from dpdfit.simulation.campaign.calibration_runs import calibration_runs
from dpdfit.simulation.campaign.pulse_runs import PULSE_TIMES_US, pulse_power
from tests.helpers.further_campaign import small_config

#: a slow memory of the harness's size: gain and phase at full drive, one time scale (us)
SLOW = {"gain_a": 0.03, "gain_p": 0.05, "tau1": 1.0}
GAIN_ABS = float(np.hypot(SLOW["gain_a"], SLOW["gain_p"]))


@pytest.fixture(scope="module")
def memory_case(tmp_path_factory):
    """A small campaign with a slow AOM memory and one pulse-response trace: its config
    and its tone-side problems with and without the trace."""
    cfg = dataclasses.replace(small_config(), pulse_traces=1).inject({"aom_memory": SLOW})
    out = tmp_path_factory.mktemp("pulse") / "c"
    simulate_campaign(out, seed=cfg.seed, config=cfg, progress=False)
    camp = load_campaign(out)
    assert camp.pulse_response is not None
    without = Problem(dataclasses.replace(camp, pulse_response=None), with_gates=False)
    return cfg, Problem(camp, with_gates=False), without


@pytest.mark.parametrize("v", [SLOW, {"tau": 80.0, "f_off": 2.0}])
def test_model_and_simulator_agree(memory_case, v):
    """The diagnosis's prediction of the normalised step response is the simulator's
    physics (its static transfer the calibrated one, not the true AOM's)."""
    cfg, prob, _ = memory_case
    aom = calibration_runs(cfg)[2]
    truth = pulse_power(dataclasses.replace(cfg, injected=()).inject({"aom_memory": v}),
                        aom, 0.4)
    p = {f"aom_memory.{k}": x for k, x in v.items()}
    model = pulse_prediction(prob.tone, p, 0.4, PULSE_TIMES_US)
    diff = np.max(np.abs(model / model[-1] - truth / truth[-1]))
    assert np.ptp(truth / truth[-1]) > 0.005
    assert diff < 0.005 * np.ptp(truth / truth[-1])


def test_static_effects_do_not_enter(memory_case):
    """Without a memory the block sees a clean step whatever the static transfer: its
    residuals do not move with a higher-order nonlinearity or a calibration mode."""
    _, prob, _ = memory_case
    _, z0 = pulse_block(prob, {})
    for p in ({"higher_order_im.k5": 0.05}, {"cal_amp0": 2.0}, {"pm_x": 0.05}):
        assert np.allclose(pulse_block(prob, p)[1], z0, rtol=0, atol=1e-9)
    _, z1 = pulse_block(prob, {f"aom_memory.{k}": x for k, x in SLOW.items()})
    assert np.sum(z1 ** 2) < np.sum(z0 ** 2) - 1000
    assert abs(np.sum(z1 ** 2) - z1.size) < 5 * np.sqrt(2 * z1.size)   # chi2 of the truth
    assert "pulse_response" in [lab["kind"] for lab, _ in prob.blocks({})]


def test_noise_from_the_trace_itself():
    rng = np.random.default_rng(4)
    steps = np.repeat([0, 1], 4000)
    power = np.r_[np.minimum(np.arange(4000), 30) / 30, 2 * np.ones(4000)]
    sig = pulse_response_noise(steps, power + 0.01 * rng.standard_normal(8000))
    assert np.allclose(sig, 0.01, rtol=0.05)


def test_pulse_table_tightens_the_memory_and_separates_it(memory_case):
    """With the trace: the memory's fitted gain has a smaller error and lies nearer the
    truth, and the memory is told from a higher-order nonlinearity by far more (the
    likelihood ratio, chi2 of the rival less the memory's, grows)."""
    _, with_pulse, without = memory_case
    sep, size = {}, {}
    for name, prob in (("without", without), ("with", with_pulse)):
        mem = fit_hypothesis(prob, (("aom_memory", "slow"),))
        him = fit_hypothesis(prob, (("higher_order_im", None),))
        sep[name] = him.chi2 - mem.chi2
        size[name] = mem.sizes["aom_memory"]["gain_abs"]
    assert size["with"].error < 0.8 * size["without"].error
    assert abs(size["with"].value - GAIN_ABS) < abs(size["without"].value - GAIN_ABS)
    assert sep["without"] > 0 and sep["with"] > 3 * sep["without"]


def test_a_campaign_without_it_is_diagnosed_as_before(memory_case):
    """The problem of the campaign without the table has exactly the blocks it had."""
    _, with_pulse, without = memory_case
    p = {f"aom_memory.{k}": x for k, x in SLOW.items()}
    got = [(lab, z) for lab, z in with_pulse.blocks(p) if lab["kind"] != "pulse_response"]
    want = without.blocks(p)
    assert [lab for lab, _ in got] == [lab for lab, _ in want]
    for (_, a), (_, b) in zip(got, want):
        assert np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True)
