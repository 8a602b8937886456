"""Phase calibration runs taken after the recordings fitted as data: predicted from the
model's phase transfer and the effects' coefficients, so a run recorded by the simulator
after an AOM's own AM-to-PM was left out of the model decides it against its rival, and
the menu offers such a run with the separation it then brings."""

import numpy as np
import pytest

from dpdfit.analyses.diagnosis.fitting.hypothesis_fit import fit_hypothesis
from dpdfit.analyses.diagnosis.model.phase_runs_block import phase_runs_block
from dpdfit.analyses.diagnosis.model.residuals import Problem
from dpdfit.analyses.diagnosis.observables.campaign import load_campaign
from dpdfit.analyses.diagnosis.proposal.expected_separation import directions, separation
from dpdfit.analyses.diagnosis.proposal.hypotheses import Hypothesis
from dpdfit.analyses.diagnosis.proposal.menu import BUILDERS
from dpdfit.core.defaults import LAB_TIMES
from dpdfit.simulation.campaign import simulate_campaign
from dpdfit.simulation.further_recordings import extend_config
from tests.helpers.further_campaign import small_config

#: the modulator's own AM-to-PM at full drive left out of the model (rad)
DPHI_X = 0.1
AM_PM = (("am_pm_omitted", "aom"),)
#: the diagnosis's strongest rival of this campaign (its ranking's second)
RIVAL = (("aom_memory", None),)


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    """The small campaign with the AOM's own AM-to-PM left out of the model, without and
    with one further phase run recorded by the simulator: their problems, and the two
    hypotheses fitted to each."""
    cfg = small_config().inject({"am_pm_omitted": {"dphi_x": DPHI_X}})
    out = {}
    for name, c in (("before", cfg),
                    ("after", extend_config(cfg, {"what": "phase_run",
                                                  "settings": {"runs": 1}}))):
        folder = tmp_path_factory.mktemp(name) / "c"
        simulate_campaign(folder, seed=c.seed, config=c, progress=False)
        prob = Problem(load_campaign(folder))
        out[name] = (prob, fit_hypothesis(prob, AM_PM), fit_hypothesis(prob, RIVAL))
    return out


def test_a_campaign_without_runs_after_the_recordings_has_no_phase_block(case):
    prob, *_ = case["before"]
    assert prob.camp.phase is not None and prob.camp.phase_runs_after is None
    assert "phase_runs" not in {lab["kind"] for lab, _ in prob.blocks({})}


def test_the_run_after_the_recordings_is_predicted_from_the_phase_transfer(case):
    prob, *_ = case["after"]
    runs = prob.camp.phase_runs_after
    assert len(runs.runs) == 1 and runs.hours[0] > 0
    n = sum(a.size for a in runs.A)
    chi2 = {dx: float(np.sum(phase_runs_block(prob, {"am_pm_omitted.dphi_x": dx})[1] ** 2))
            for dx in (0.0, DPHI_X)}
    # at the injected size the run is its noise (chi2 with n dof, the recorded errors
    # being conservative), without it the run is far off
    assert chi2[DPHI_X] < n + 3 * np.sqrt(2 * n)
    assert chi2[0.0] > 100 * n
    # a phase after the AOM (the beam path) is not seen by a phase run of the AOM
    z0 = phase_runs_block(prob, {})[1]
    assert np.array_equal(phase_runs_block(prob, {"am_pm_omitted.dphi": 0.1})[1], z0)
    # the other phase-sign convention with the phase-odd parameter flipped predicts the same
    flipped = prob.tone.with_phase_sign(-prob.tone.phase_sign)
    saved = prob.tone
    try:
        prob.tone = flipped
        z_flip = phase_runs_block(prob, {"am_pm_omitted.dphi_x": -DPHI_X})[1]
    finally:
        prob.tone = saved
    np.testing.assert_allclose(z_flip, phase_runs_block(
        prob, {"am_pm_omitted.dphi_x": DPHI_X})[1], rtol=0, atol=1e-9)
    assert "phase_runs" in {lab["kind"] for lab, _ in prob.blocks({})}


def test_the_run_moves_the_separation_toward_the_truth(case):
    """The rival's chi2 grows by what the run shows, the truth's by little more than the
    run's noise (the spectra of this small campaign pull the size to 0.107, the run to
    0.1); the fitted size moves toward the truth and its error shrinks."""
    sep = {k: rival.chi2 - am.chi2 for k, (_, am, rival) in case.items()}
    n = sum(a.size for a in case["after"][0].camp.phase_runs_after.A)
    assert sep["before"] > 0
    assert sep["after"] - sep["before"] > 100 * n
    (_, before, rb), (_, after, ra) = case["before"], case["after"]
    assert after.chi2 - before.chi2 < 0.01 * (ra.chi2 - rb.chi2)
    key = "am_pm_omitted.dphi_x"
    assert abs(after.params[key] - DPHI_X) < abs(before.params[key] - DPHI_X)
    assert after.params_err[key] < before.params_err[key]


def test_the_menu_offers_the_run_with_the_separation_it_brings(case):
    prob, am, rival = case["before"]
    ha, hb = Hypothesis(prob, am), Hypothesis(prob, rival)
    items = [it for b in BUILDERS for it in b(prob, [ha, hb], LAB_TIMES)]
    (item,) = [it for it in items if it.what == "phase_run"]
    assert item.seconds == LAB_TIMES.phase_run_s and item.settings == {"runs": 1}
    # the points a further run records: the model's run's at A >= 0.1
    assert item.vector(ha).size == prob.camp.phase_points[0].size
    dirs = directions(item, [[ha], [hb]], True)
    expected, _ = separation(dirs, 1)
    assert np.isfinite(expected) and expected > 100
    # the rival refitted (linearised and exactly) absorbs part of the fixed difference
    assert expected <= separation(dirs, 1, "fixed")[0]
    assert separation(dirs, 1, "refit")[0] == pytest.approx(expected, rel=0.05)
    # what the recorded run achieved is the expected figure to within the run's noise and
    # the fitted size's error (the truth's 0.1 rad against the fit's 0.107)
    achieved = ((case["after"][2].chi2 - case["after"][1].chi2)
                - (rival.chi2 - am.chi2))
    assert 0.7 < achieved / expected < 1.4


def test_not_offered_without_recording_times(case):
    import dataclasses
    prob, am, rival = case["before"]
    bare = object.__new__(Problem)
    bare.__dict__.update(prob.__dict__)
    bare.camp = dataclasses.replace(prob.camp, recorded={})
    hyps = [Hypothesis(bare, am), Hypothesis(bare, rival)]
    assert not [it for b in BUILDERS for it in b(bare, hyps, LAB_TIMES)
                if it.what == "phase_run"]
