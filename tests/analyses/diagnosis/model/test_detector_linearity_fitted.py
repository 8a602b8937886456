"""detector_linearity.csv fitted as data: predicted through the effects' photodiode hook,
so it constrains a detector nonlinearity and not a stale table."""

import dataclasses

import numpy as np
import pytest

from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.analyses.diagnosis.fitting.hypothesis_fit import fit_hypothesis
from dpdfit.analyses.diagnosis.model.linearity_block import (linearity_block,
                                                             predicted_attenuated)
from dpdfit.analyses.diagnosis.model.residuals import Problem
from dpdfit.analyses.diagnosis.observables.campaign import load_campaign
from dpdfit.analyses.diagnosis.observables.detector_linearity import linearity_data
from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.recordings.detector_linearity import transmission
from dpdfit.simulation.campaign import simulate_campaign
from dpdfit.simulation.campaign.calibration_runs import calibration_runs
from dpdfit.simulation.campaign.detector_linearity_runs import linearity_rows
import dpdfit.simulation.harness as H
from tests.helpers.further_campaign import SEED

K = 0.1
DET = (("detector_nonlinearity", "linear"),)
STALE = (("stale_calibration", None),)


def tone_config():
    """The harness campaign with fewer calibration runs (its spectra whole: the tone side
    fits; the closed loop's smaller campaign has four trace amplitudes, on which the gate
    tone's power alone is misfit by chi2 ~ 5e4 with no effect injected)."""
    return dataclasses.replace(H.harness_config(SEED), n_amp_runs=5,
                               runs_after_recordings=1, cal_points=41)


@pytest.fixture(scope="module")
def det_case(tmp_path_factory):
    """A small campaign (no gates) with a nonlinear photodiode and no linearity table:
    its config, its day's AOM and its problem."""
    cfg = tone_config().inject({"detector_nonlinearity": {"k": K}})
    out = tmp_path_factory.mktemp("det") / "c"
    simulate_campaign(out, seed=cfg.seed, config=cfg, progress=False, include_gates=False)
    return cfg, calibration_runs(cfg)[2], Problem(load_campaign(out), with_gates=False)


def _with_table(prob, rows):
    """A shallow copy of ``prob`` whose campaign has ``rows`` as its detector_linearity.csv
    (the models and nuisances shared: only the data block differs)."""
    rows = rows.assign(transmission=transmission(rows["attenuation_db"]))
    data = linearity_data(rows, CampaignFolder(prob.camp.folder).amplitude_model, None,
                          prob.camp.amplitude)
    out = object.__new__(Problem)
    out.__dict__.update(prob.__dict__)
    out.camp = dataclasses.replace(prob.camp, detector_linearity=data)
    return out


def test_prediction_is_the_effects_photodiode(det_case):
    """Linear photodiode: the attenuated reading is T P, whatever the tone effects do;
    a nonlinear one: the reading of the attenuated true power (round trip exact)."""
    _, _, prob = det_case
    P = np.array([0.2, 1.0, 1.9])
    T = 0.1
    assert np.allclose(predicted_attenuated(prob, {}, P, T), T * P, rtol=1e-14)
    for name, e in EFFECTS.items():
        if name == "detector_nonlinearity" or e.side != "tones":
            continue
        p = {e.key(x.name): x.start + 3 * x.scale for x in e.params}
        assert np.allclose(predicted_attenuated(prob, p, P, T), T * P, rtol=1e-14), name
    k, q = 0.08, 1.7
    got = predicted_attenuated(prob, {"detector_nonlinearity.k": k,
                                      "detector_nonlinearity.q": q}, P, T)
    Pm = prob.tone.P_max
    u_t = np.array([_solve(x / Pm, k, q) for x in P])
    assert np.allclose(got, Pm * T * u_t * (1 + k * (T * u_t) ** q), rtol=1e-6)


def _solve(u_read, k, q):
    lo, hi = 0.0, 2.0 * u_read + 1.0
    for _ in range(200):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if mid * (1 + k * mid ** q) < u_read else (lo, mid)
    return (lo + hi) / 2


def test_detector_constrained_stale_table_not(det_case):
    cfg, aom, prob = det_case
    prob = _with_table(prob, linearity_rows(cfg, aom, 10, np.random.default_rng(0)))
    _, z0 = linearity_block(prob, {})
    assert np.array_equal(linearity_block(prob, {"stale_calibration.y1_drift": 0.03})[1], z0)
    _, z1 = linearity_block(prob, {"detector_nonlinearity.k": K})
    assert np.sum(z1 ** 2) < 0.1 * np.sum(z0 ** 2)
    assert "linearity" in [lab["kind"] for lab, _ in prob.blocks({})]


def _true_k_det(prob, cfg):
    """The reading error at the recorded curve's largest true power, the size the fit
    reports: ``k Pm/p_full`` with ``P_max = Pm (1 + k Pm/p_full)``."""
    x = K * prob.tone.P_max / cfg.photodiode.p_full
    return (-1 + np.sqrt(1 + 4 * x)) / 2


def test_table_tightens_the_detector_size(det_case):
    """Over a few linearity draws: the fitted reading error is within 3 sigma of the truth
    and its error smaller than the calibration runs' and spectra's alone."""
    cfg, aom, prob = det_case
    assert prob.camp.detector_linearity is None
    alone = fit_hypothesis(prob, DET).sizes["detector_nonlinearity"]["k_det"]
    truth = _true_k_det(prob, cfg)
    for seed in range(3):
        with_table = _with_table(prob, linearity_rows(cfg, aom, 10,
                                                      np.random.default_rng(seed)))
        size = fit_hypothesis(with_table, DET).sizes["detector_nonlinearity"]["k_det"]
        assert abs(size.value - truth) < 3 * size.error
        assert size.error < 0.9 * alone.error


def test_table_separates_detector_from_stale_table(det_case):
    """BIC(stale table) - BIC(detector) grows with the table, in every draw."""
    cfg, aom, prob = det_case
    before = fit_hypothesis(prob, STALE).bic - fit_hypothesis(prob, DET).bic
    for seed in range(2):
        with_table = _with_table(prob, linearity_rows(cfg, aom, 10,
                                                      np.random.default_rng(seed)))
        after = fit_hypothesis(with_table, STALE).bic - fit_hypothesis(with_table, DET).bic
        assert after > before + 50


def test_campaign_without_table_is_read_as_before(tmp_path):
    """The table's own stream: every other file is the same; without it the problem has
    no linearity block and the same residuals as the other blocks of one with it."""
    cfg = tone_config()
    a, b = tmp_path / "a", tmp_path / "b"
    simulate_campaign(a, seed=cfg.seed, config=cfg, progress=False, include_gates=False)
    simulate_campaign(b, seed=cfg.seed, progress=False, include_gates=False,
                      config=dataclasses.replace(cfg, detector_linearity_points=10))
    names = {p.name for p in b.iterdir()} - {"detector_linearity.csv", "truth.json"}
    assert names == {p.name for p in a.iterdir()} - {"truth.json"}
    for n in names:
        if (a / n).is_file():
            assert (a / n).read_bytes() == (b / n).read_bytes(), n
    pa, pb = Problem(load_campaign(a), with_gates=False), Problem(load_campaign(b),
                                                                 with_gates=False)
    assert pa.camp.detector_linearity is None
    p = {"detector_nonlinearity.k": 0.02}
    ba = pa.blocks(p)
    bb = [(lab, z) for lab, z in pb.blocks(p) if lab["kind"] != "linearity"]
    assert [lab for lab, _ in ba] == [lab for lab, _ in bb]
    for (_, za), (_, zb) in zip(ba, bb):
        assert np.array_equal(np.ravel(za), np.ravel(zb), equal_nan=True)


def test_null_model_says_where_the_noise_comes_from(det_case):
    cfg, aom, prob = det_case
    assert "detector_linearity_noise" not in prob.null_model().to_dict()
    rows = linearity_rows(cfg, aom, 10, np.random.default_rng(0))
    said = _with_table(prob, rows).null_model().to_dict()["detector_linearity_noise"]
    assert said.startswith("power: power_err; power_attenuated: ")
    said = _with_table(prob, rows.drop(columns="power_err")).null_model().to_dict()[
        "detector_linearity_noise"]
    assert said.startswith("both readings: ")
