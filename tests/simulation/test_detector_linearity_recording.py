"""The simulator records the detector linearity characterisation
(``detector_linearity.csv``): the true AOM's power read with and without the attenuator;
only a nonlinear photodiode changes the readings' ratio."""

import dataclasses
import json

import numpy as np
import pytest

from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.simulation import injections
from dpdfit.simulation.campaign import CampaignConfig, simulate_campaign
from dpdfit.simulation.campaign.calibration_runs import calibration_runs
from dpdfit.simulation.campaign.detector_linearity_runs import (
    ATTENUATION_DB, expected_readings, linearity_drives, linearity_table)
from dpdfit.simulation.further_recordings import extend_config
from dpdfit.simulation.recorded_schedule import difference_rows, record_further
from tests.helpers.further_campaign import small_config

#: the effects whose physics touches the photodiode's reading
TOUCHES_RATIO = {"detector_nonlinearity"}
#: the effects that move the AOM's power at the recordings (a test that sees only the
#: ratio would be vacuous without one)
MOVES_POWER = {"stale_calibration"}
_CFG = dataclasses.replace(CampaignConfig(seed=3), n_amp_runs=4, cal_points=21)
_A = linearity_drives(10)


def _expected(cfg):
    aom = calibration_runs(cfg)[2]
    return expected_readings(cfg, aom, _A)


@pytest.mark.parametrize("name", sorted(injections.INJECTIONS))
def test_only_a_nonlinear_photodiode_changes_the_ratio(name):
    inj = injections.get(name)
    table = inj.harness_table()
    if not table:
        pytest.skip(f"{name}: the harness does not conceal it")
    p0, pa0 = _expected(_CFG)
    assert np.allclose(pa0 / p0, 10 ** (-ATTENUATION_DB / 10), rtol=1e-12)
    ratio_changed = power_changed = False
    for form in table:
        v = inj.draw(np.random.default_rng(1), form)
        p, pa = _expected(_CFG.inject({name: v}))
        ratio_changed |= not np.allclose(pa / p, pa0 / p0, rtol=1e-9)
        power_changed |= not np.allclose(pa, pa0, rtol=1e-9)
    assert ratio_changed == (name in TOUCHES_RATIO)
    if name in MOVES_POWER:
        assert power_changed


def test_nonlinear_ratio_changes_with_power():
    v = {"k": 0.1, "q": 1.0}
    cfg = _CFG.inject({"detector_nonlinearity": v})
    aom = calibration_runs(cfg)[2]
    p, pa = expected_readings(cfg, aom, _A)
    r = 10 ** (-ATTENUATION_DB / 10)
    ratio = pa / p / r
    # saturation towards full scale: true power P read P (1 + k P/p_full), so the ratio
    # (1 + k r u) / (1 + k u) falls with the power
    assert np.all(np.diff(ratio) < 0)
    u = cfg.photodiode.p_full * aom.efficiency(_A) / aom.eta_ref / cfg.photodiode.p_full
    assert ratio == pytest.approx((1 + 0.1 * r * u) / (1 + 0.1 * u), rel=1e-12)


def test_simulated_campaign_writes_it_only_when_asked(tmp_path):
    cfg = dataclasses.replace(small_config(), detector_linearity_points=10).inject(
        {"detector_nonlinearity": {"k": 0.1}})
    out = tmp_path / "c"
    simulate_campaign(out, seed=cfg.seed, config=cfg, progress=False)
    truth = json.loads((out / "truth.json").read_text())
    assert truth["config"]["detector_linearity_points"] == 10
    assert truth["detector_linearity"]["ratio_change_at_full_scale"] < -0.05
    assert CampaignConfig.from_truth(truth).detector_linearity_points == 10
    df = CampaignFolder(out).detector_linearity
    assert df["A"].tolist() == pytest.approx(list(_A))
    # the noise is the calibration runs': the ratio at the weakest drive ~ 1/10
    assert df["power_attenuated"].iloc[0] / df["power"].iloc[0] == pytest.approx(0.1, rel=0.05)
    # a campaign without it writes neither file nor truth
    plain = tmp_path / "p"
    simulate_campaign(plain, seed=cfg.seed, config=small_config(), progress=False)
    assert not (plain / "detector_linearity.csv").exists()
    assert "detector_linearity" not in json.loads((plain / "truth.json").read_text())


def test_further_recording_is_its_own_rows():
    cfg = small_config()
    m = [{"what": "detector_linearity", "settings": {"points": 6}}]
    assert extend_config(cfg, m[0]).further == (("detector_linearity", 6),)
    rec = record_further(cfg, m)
    assert list(rec.tables) == ["detector_linearity"]
    assert len(rec.tables["detector_linearity"]) == 6
    long = difference_rows(cfg, m, include_spectra=False, include_gates=False)
    assert rec.tables["detector_linearity"].equals(long["detector_linearity"])
    aom = calibration_runs(cfg)[2]
    assert linearity_table(cfg, aom).empty
