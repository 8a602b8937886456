"""The simulator records the sideband thermometry (``thermometry.csv``): the true motional
state and preparation after the injected effects, binomial counts, changed only by
effects that touch them."""

import dataclasses
import json

import numpy as np
import pytest

from dpdfit.models.sideband_thermometry import (bright_probability, mean_occupation,
                                                sideband_excitation)
from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.simulation import injections
from dpdfit.simulation.campaign import CampaignConfig, simulate_campaign
from dpdfit.simulation.campaign.thermometry_runs import (THERMOMETRY_WAITS_US,
                                                         thermometry_engine,
                                                         thermometry_table)
from dpdfit.simulation.further_recordings import extend_config
from dpdfit.simulation.recorded_schedule import difference_rows, record_further
from tests.helpers.further_campaign import small_config

#: the effects whose physics touches the mode's occupation or the probed ion's
#: preparation and detection
TOUCHES_THERMOMETRY = {"motional_heating", "higher_nbar", "spam_offset"}


def test_weak_probe_gives_the_sideband_ratio_and_pi_pulse_the_ground_state():
    nbar = np.array([0.05, 0.5, 2.0])
    red = sideband_excitation(nbar, "red", 1e-3)
    blue = sideband_excitation(nbar, "blue", 1e-3)
    assert red / blue == pytest.approx(nbar / (nbar + 1), rel=1e-5)
    # the pi pulse: the ground state fully excited on blue, untouched on red
    assert sideband_excitation([0.0, 0.0], ["blue", "red"]) == pytest.approx([1.0, 0.0])
    # errors: a spectator reads bright, detection flips the reading
    p = bright_probability([0.0], "blue", 0.1, 0.0, 0.0, 0.0)
    assert p == pytest.approx(0.1)
    assert bright_probability([0.0], "red", 0.0, 0.0, 0.01, 0.0) == pytest.approx(0.99)


@pytest.mark.parametrize("name", sorted(injections.INJECTIONS))
def test_only_effects_touching_occupation_or_preparation_change_it(name):
    cfg = CampaignConfig(seed=3)
    inj = injections.get(name)
    table = inj.harness_table()
    if not table:
        pytest.skip(f"{name}: the harness does not conceal it")
    changed = False
    for form in table:
        v = inj.draw(np.random.default_rng(1), form)
        got = thermometry_engine(cfg.inject({name: v}))
        changed |= got != thermometry_engine(cfg)
    assert changed == (name in TOUCHES_THERMOMETRY)


def test_simulated_campaign_writes_it_only_when_asked(tmp_path):
    cfg = dataclasses.replace(small_config(), thermometry_shots=3000).inject(
        {"motional_heating": {"ndot": 0.1}})
    table = thermometry_table(cfg)
    assert table["sideband"].tolist() == ["red", "blue"] * len(THERMOMETRY_WAITS_US)
    e = thermometry_engine(cfg)
    assert e["ndot"] == pytest.approx(cfg.ndot + 100.0)
    # every point within binomial noise of the model at the true occupation
    p = bright_probability(mean_occupation(e["nbar"], e["ndot"], table["wait_us"] * 1e-6),
                           table["sideband"].to_numpy(), e["p_prep"], e["p_flip"],
                           e["e01"], e["e10"])
    z = (table["n_bright"] - 3000 * p) / np.sqrt(3000 * p * (1 - p))
    assert np.all(np.abs(z) < 4.5)
    # the red sideband darkens as the mode heats
    red = table[table["sideband"] == "red"]["n_bright"].to_numpy()
    assert red[0] > red[-1] + 300
    assert thermometry_table(small_config()).empty
    out = tmp_path / "c"
    simulate_campaign(out, seed=cfg.seed, config=cfg, progress=False)
    truth = json.loads((out / "truth.json").read_text())
    assert truth["thermometry"]["heating_quanta_per_s"] == pytest.approx(cfg.ndot + 100.0)
    assert truth["config"]["thermometry_shots"] == 3000
    assert CampaignConfig.from_truth(truth).thermometry_shots == 3000
    assert CampaignFolder(out).thermometry["shots"].tolist() == [3000] * len(table)


def test_further_thermometry_recording_is_its_own_rows():
    cfg = small_config()
    m = [{"what": "thermometry", "settings": {"shots": 200}}]
    assert extend_config(cfg, m[0]).further == (("thermometry", 200),)
    rec = record_further(cfg, m)
    assert list(rec.tables) == ["thermometry"]
    long = difference_rows(cfg, m, include_spectra=False, include_gates=False)
    assert rec.tables["thermometry"].equals(long["thermometry"])
