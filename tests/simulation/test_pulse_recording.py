"""The simulator records the AOM pulse response (``pulse_response.csv``): the optical power
after an RF step through the campaign's AOM and the injected effects, whose shape only a
memory of the modulator changes."""

import dataclasses
import json

import numpy as np
import pytest

from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.simulation import injections
from dpdfit.simulation.campaign import CampaignConfig, simulate_campaign
from dpdfit.simulation.campaign.calibration_runs import calibration_runs
from dpdfit.simulation.campaign.pulse_runs import PULSE_TIMES_US, pulse_power, pulse_table
from dpdfit.simulation.further_recordings import extend_config
from dpdfit.simulation.recorded_schedule import difference_rows, record_further
from tests.helpers.further_campaign import small_config

#: the effects whose physics is a memory of the modulator: the only ones that change the
#: response normalised to its settled level
TOUCHES_SHAPE = {"aom_memory"}


@pytest.fixture(scope="module")
def aom():
    return calibration_runs(CampaignConfig(seed=3))[2]


def _shape(cfg, aom, A=0.5):
    p = pulse_power(cfg, aom, A)
    return p / p[-1], p[-1]


@pytest.mark.parametrize("name", sorted(injections.INJECTIONS))
def test_only_a_memory_changes_the_normalised_response(name, aom):
    """Over every form the harness draws: the normalised step response changes exactly for
    the memory; the settled level may change with a static transfer or detector."""
    cfg = CampaignConfig(seed=3)
    inj = injections.get(name)
    table = inj.harness_table()
    if not table:
        pytest.skip(f"{name}: the harness does not conceal it")
    base, _ = _shape(cfg, aom)
    assert np.array_equal(base, np.ones_like(base))     # a memoryless AOM: a clean step
    changed = []
    for form in table:
        v = inj.draw(np.random.default_rng(1), form)
        shape, _ = _shape(cfg.inject({name: v}), aom)
        changed.append(np.max(np.abs(shape - base)) > 1e-3)
    if name in TOUCHES_SHAPE:
        assert all(changed)
    else:
        assert not any(changed)


def test_static_effects_move_the_settled_level_only(aom):
    cfg = CampaignConfig(seed=3)
    _, level = _shape(cfg, aom)
    for name in ("detector_nonlinearity", "higher_order_im"):
        v = injections.get(name).draw(np.random.default_rng(1))
        shape, moved = _shape(cfg.inject({name: v}), aom)
        assert abs(moved / level - 1) > 1e-3
        assert np.allclose(shape, 1.0, rtol=0, atol=1e-12)


def test_slow_memory_is_the_gain_through_its_kernel(aom):
    """One time scale: the field's gain ``1 + c s(t)`` relative to the steady state, ``s``
    rising as ``A^2 (1 - exp(-t/tau1))``: the normalised power is
    ``|1 + c A^2 (1 - e^{-t/tau})|^2 / |1 + c A^2|^2``."""
    v = {"gain_a": 0.05, "gain_p": 0.0, "tau1": 1.0, "tau2": 3.0, "w": 0.0, "delay": 0.0}
    shape, _ = _shape(CampaignConfig(seed=3).inject({"aom_memory": v}), aom)
    s = 0.25 * (1 - np.exp(-PULSE_TIMES_US / 1.0))
    want = (1 + 0.05 * s) ** 2 / (1 + 0.05 * 0.25) ** 2
    # the kernel discretised on the 2 ns grid: ~dt/tau (2e-3) of the 5 % gain change
    assert np.allclose(shape, want / want[-1], rtol=0, atol=1e-4)


def test_simulated_campaign_writes_it_only_when_asked(tmp_path):
    cfg = dataclasses.replace(small_config(), pulse_traces=2).inject(
        {"aom_memory": {"gain_a": 0.05, "tau1": 1.0}})
    aom = calibration_runs(cfg)[2]
    table = pulse_table(cfg, aom)
    assert table["run"].unique().tolist() == ["pulse1", "pulse2"]
    assert (table["A"] == cfg.time_scan_A).all() and (table["power"] >= 0).all()
    one = table[table["run"] == "pulse1"]
    p = pulse_power(cfg, aom, cfg.time_scan_A)
    z = (one["power"].to_numpy() - p) / one["power_err"].to_numpy()
    assert abs(z.mean()) < 5 / np.sqrt(z.size) and abs(z.std() - 1) < 0.05
    assert pulse_table(small_config(), aom).empty
    out = tmp_path / "c"
    simulate_campaign(out, seed=cfg.seed, config=cfg, progress=False)
    truth = json.loads((out / "truth.json").read_text())
    assert truth["pulse_response"]["A"] == [cfg.time_scan_A] * 2
    assert truth["config"]["pulse_traces"] == 2
    assert CampaignConfig.from_truth(truth).pulse_traces == 2
    got = CampaignFolder(out).pulse_response
    assert got["step"].nunique() == 2 and len(got) == 2 * PULSE_TIMES_US.size


def test_further_pulse_recording_is_its_own_rows():
    cfg = small_config()
    m = [{"what": "pulse_response", "settings": {"A": 0.7}}]
    assert extend_config(cfg, m[0]).further == (("pulse_response", 0.7),)
    rec = record_further(cfg, m)
    assert list(rec.tables) == ["pulse_response"]
    long = difference_rows(cfg, m, include_spectra=False, include_gates=False)
    assert rec.tables["pulse_response"].equals(long["pulse_response"])
    assert set(rec.tables["pulse_response"]["A"]) == {"0.7"} or set(
        rec.tables["pulse_response"]["A"].astype(float)) == {0.7}
