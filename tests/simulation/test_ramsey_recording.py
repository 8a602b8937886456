"""The simulator records the Ramsey and spin-echo characterisation (``ramsey.csv``): the
true free-precession dephasing and SPAM after the injected effects, multinomial counts,
changed only by effects that dephase the qubit or touch its preparation and detection."""

import dataclasses
import json

import numpy as np
import pytest

from dpdfit.models.ramsey import ramsey_probabilities
from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.simulation import injections
from dpdfit.simulation.campaign import CampaignConfig, simulate_campaign
from dpdfit.simulation.campaign.ramsey_runs import (RAMSEY_POINTS, ramsey_dephasing,
                                                    ramsey_engine, ramsey_table,
                                                    ramsey_waits)
from tests.helpers.further_campaign import small_config

#: the effects whose physics touches free precession, preparation or detection
TOUCHES_RAMSEY = {"dephasing", "spam_offset"}
REFS = {"t_ref": 2.5e-4, "A_ref": 0.6}


def _expected(cfg):
    """Both sequences' outcome probabilities at the scan's waits."""
    kw = ramsey_engine(cfg, REFS)
    det = kw["p_det"]
    t = ramsey_waits(cfg.T2)
    return np.stack([ramsey_probabilities(*ramsey_dephasing(cfg, REFS, t, echo),
                                          kw["p_prep"], kw.get("p_flip", 0.0), det, det)
                     for echo in (False, True)])


def test_probabilities_of_the_two_ions():
    # coherent: both dark; fully dephased independently: each dark half the time
    assert ramsey_probabilities(0.0, 0.0)[()] == pytest.approx([0, 0, 1])
    assert ramsey_probabilities(50.0, 0.0)[()] == pytest.approx([0.25, 0.5, 0.25])
    # fully dephased by common noise: phi_1 = phi_2, both dark with <(1 + cos)^2>/4 = 3/8
    assert ramsey_probabilities(0.0, 50.0)[()] == pytest.approx([0.375, 0.25, 0.375])
    # a spectator reads bright: one ion of two absent from the dark count
    p = ramsey_probabilities(0.0, 0.0, spectator=0.1)
    assert p[()] == pytest.approx([0.01, 0.18, 0.81])
    assert np.allclose(ramsey_probabilities(np.linspace(0, 3, 7), 0.2, 0.01, 0.003, 1e-3,
                                            2e-3).sum(axis=-1), 1.0)


@pytest.mark.parametrize("name", sorted(injections.INJECTIONS))
def test_only_effects_touching_free_precession_change_it(name):
    cfg = CampaignConfig(seed=3)
    inj = injections.get(name)
    table = inj.harness_table()
    if not table:
        pytest.skip(f"{name}: the harness does not conceal it")
    changed = False
    for form in table:
        v = inj.draw(np.random.default_rng(1), form)
        changed |= not np.allclose(_expected(cfg.inject({name: v})), _expected(cfg),
                                   rtol=0, atol=1e-12)
    assert changed == (name in TOUCHES_RAMSEY)


@pytest.mark.parametrize("form, echo_changes", [
    ("independent", True), ("common", True), ("stretched", False),
    ("coherence", True), ("coherence_stretched", False)])
def test_the_echo_removes_slow_noise_only(form, echo_changes):
    """White dephasing (beta = 1) costs the echo what it costs Ramsey; slow noise (beta >
    1, during the gate or on the coherences) costs Ramsey and not the echo."""
    cfg = CampaignConfig(seed=3)
    v = {"rate": 80.0, **injections.get("dephasing").form_values(form)}
    if "stretched" in form:
        v.update(beta=2.0, f_cm=0.3)
    base, got = _expected(cfg), _expected(cfg.inject({"dephasing": v}))
    assert not np.allclose(got[0], base[0], atol=1e-6)
    assert (not np.allclose(got[1], base[1], atol=1e-9)) == echo_changes


def test_simulated_campaign_writes_it_only_when_asked(tmp_path):
    cfg = dataclasses.replace(small_config(), ramsey_shots=300).inject(
        {"dephasing": {"rate": 60.0, "f_cm": 1.0}})
    out = tmp_path / "c"
    simulate_campaign(out, seed=cfg.seed, config=cfg, progress=False)
    truth = json.loads((out / "truth.json").read_text())
    assert truth["config"]["ramsey_shots"] == 300
    assert CampaignConfig.from_truth(truth).ramsey_shots == 300
    assert truth["ramsey"]["T2_corr_s"] == pytest.approx(1 / 60.0)
    df = CampaignFolder(out).ramsey
    assert df["sequence"].tolist() == ["ramsey"] * RAMSEY_POINTS + ["echo"] * RAMSEY_POINTS
    assert (df["shots"] == 300).all()
    # the counts are multinomial around the truth's dephasing (Pearson chi2 over 2 x 20
    # points of 2 degrees of freedom each: 80 +- 13)
    chi2 = 0.0
    for seq in ("ramsey", "echo"):
        g = truth["ramsey"][seq]
        p = ramsey_probabilities(np.array(g["G_i"]), np.array(g["G_c"]), cfg.p_prep, 0.0,
                                 cfg.p_det, cfg.p_det)
        n = df[df["sequence"] == seq][["n00", "n01_10", "n11"]].to_numpy(float)
        chi2 += float(np.sum((n - 300 * p) ** 2 / np.maximum(300 * p, 1e-3)))
    assert chi2 < 80 + 5 * np.sqrt(160)
    # the injected common white rate, accumulated over the longest wait (1.5 T2)
    assert truth["ramsey"]["ramsey"]["G_c"][-1] == pytest.approx(60.0 * 0.075, rel=1e-6)
    assert ramsey_table(small_config(), REFS).empty
    plain = tmp_path / "p"
    simulate_campaign(plain, seed=cfg.seed, config=small_config(), progress=False)
    assert not (plain / "ramsey.csv").exists()
    assert "ramsey" not in json.loads((plain / "truth.json").read_text())
    assert "ramsey_shots" not in json.loads((plain / "truth.json").read_text())["config"]
