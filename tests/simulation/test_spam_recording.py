"""The simulator records the SPAM characterisation (``spam.csv``): its true preparation and
detection errors, multinomial counts, changed only by effects that touch them."""

import dataclasses
import json

import numpy as np
import pytest

from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.simulation import injections
from dpdfit.simulation.campaign import CampaignConfig, simulate_campaign
from dpdfit.simulation.campaign.spam_runs import spam_engine, spam_probabilities, spam_table
from dpdfit.simulation.further_recordings import extend_config
from dpdfit.simulation.recorded_schedule import difference_rows, record_further
from tests.helpers.further_campaign import small_config

#: the effects whose physics touches preparation or detection
TOUCHES_SPAM = {"spam_offset"}


def test_probabilities_are_the_preparation_then_the_detection():
    p = spam_probabilities(0.01, 0.002, 1e-3, 2e-3, ("00", "11", "01"))
    assert np.allclose(p.sum(axis=1), 1.0)
    dark0 = 0.002 * (1 - 2e-3) + 0.998 * 1e-3
    dark1 = (1 - 0.012) * (1 - 2e-3) + 0.012 * 1e-3
    assert p[0] == pytest.approx([(1 - dark0) ** 2, 2 * dark0 * (1 - dark0), dark0 ** 2])
    assert p[1] == pytest.approx([(1 - dark1) ** 2, 2 * dark1 * (1 - dark1), dark1 ** 2])
    assert p[2, 1] == pytest.approx(dark0 * (1 - dark1) + dark1 * (1 - dark0))
    # a spectator reads bright whatever is prepared: invisible in |00>, seen in |11>
    q = spam_probabilities(0.05, 0.0, 0.0, 0.0)
    assert q[0] == pytest.approx([1, 0, 0]) and q[1, 0] == pytest.approx(0.05 ** 2)


@pytest.mark.parametrize("name", sorted(injections.INJECTIONS))
def test_only_effects_touching_preparation_change_its_expectation(name):
    cfg = CampaignConfig(seed=3)
    inj = injections.get(name)
    table = inj.harness_table()
    if not table:
        pytest.skip(f"{name}: the harness does not conceal it")
    changed = False
    for form in table:
        v = inj.draw(np.random.default_rng(1), form)
        got = spam_engine(cfg.inject({name: v}))
        changed |= got != spam_engine(cfg)
    assert changed == (name in TOUCHES_SPAM)


def test_simulated_campaign_writes_it_only_when_asked(tmp_path):
    cfg = dataclasses.replace(small_config(), spam_shots=2000).inject(
        {"spam_offset": {"p_extra": 0.02}})
    table = spam_table(cfg)
    assert table["prepared"].tolist() == ["00", "11"]
    assert (table[["n00", "n01_10", "n11"]].sum(axis=1) == 2000).all()
    e = spam_engine(cfg)
    assert e["p_prep"] == pytest.approx(cfg.p_prep + 0.02)
    # |11>: an ion reads bright with probability ~ p_prep + p_extra (a spectator)
    bright = (2 * table["n00"] + table["n01_10"])[1] / 4000
    assert abs(bright - (e["p_prep"] + e["e10"])) < 5 * np.sqrt(0.023 / 4000)
    assert spam_table(small_config()).empty
    # written with its truth; a campaign without it has neither (its files as before)
    out = tmp_path / "c"
    simulate_campaign(out, seed=cfg.seed, config=cfg, progress=False)
    truth = json.loads((out / "truth.json").read_text())
    assert truth["spam"]["spectator"] == pytest.approx(cfg.p_prep + 0.02)
    assert truth["config"]["spam_shots"] == 2000
    assert CampaignConfig.from_truth(truth).spam_shots == 2000
    assert CampaignFolder(out).spam["shots"].tolist() == [2000, 2000]


def test_further_spam_recording_is_its_own_rows():
    cfg = small_config()
    m = [{"what": "spam", "settings": {"shots": 800}}]
    assert extend_config(cfg, m[0]).further == (("spam", 800),)
    rec = record_further(cfg, m)
    assert list(rec.tables) == ["spam"]
    long = difference_rows(cfg, m, include_spectra=False, include_gates=False)
    assert rec.tables["spam"].equals(long["spam"])
