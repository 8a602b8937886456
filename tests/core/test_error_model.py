"""The lab's error model is defined once (dpdfit.core.defaults.ErrorModel) and used everywhere."""

from __future__ import annotations

import dataclasses
import inspect
import json

import numpy as np
import pytest

from dpdfit.core.defaults import ERROR_MODEL, NBAR, ErrorModel
from dpdfit.errors import InputError
from tests.helpers.paths import ROOT


def test_default_instance_values():
    assert ERROR_MODEL == ErrorModel()
    assert ERROR_MODEL.to_dict() == {
        "nbar": NBAR, "T2_s": 0.05, "heating_quanta_per_s": 5.0, "p_prep": 0.003,
        "p_det": 5e-5, "power_jitter_db": 0.2, "xi0_rel_err": 0.01, "parity_phases": 16,
        "table_points": 4096, "seed": 20260329}
    assert NBAR == 0.1


def test_campaign_keys_are_those_of_the_bundled_campaign():
    meta = json.loads((ROOT / "datasets" / "synthetic_campaign" / "campaign.json").read_text())
    assert set(ErrorModel.CAMPAIGN_KEYS) == set(meta["error_model"])
    assert ERROR_MODEL.campaign_dict() == meta["error_model"]
    assert ErrorModel.from_dict(meta["error_model"]) == ERROR_MODEL
    assert meta["parity_phases"] == ERROR_MODEL.parity_phases
    assert meta["predistortion_table"]["points"] == ERROR_MODEL.table_points


def test_round_trip_and_overlay():
    other = ErrorModel(T2_s=0.04, p_det=1e-4, parity_phases=8, seed=7)
    assert ErrorModel(**other.to_dict()) == other
    assert ErrorModel.from_dict(other.campaign_dict(), base=other) == other
    assert ErrorModel.from_dict(ERROR_MODEL.campaign_dict()) == ERROR_MODEL
    assert ErrorModel.from_dict({}) == ERROR_MODEL
    # a campaign's error_model over the defaults; over another base
    assert ErrorModel.from_dict({"T2_s": 0.04}) == dataclasses.replace(ERROR_MODEL, T2_s=0.04)
    assert ErrorModel.from_dict({"p_prep": 0.01}, base=other) == dataclasses.replace(
        other, p_prep=0.01)
    # JSON integers become floats, as the campaign's values are read
    em = ErrorModel.from_dict({"heating_quanta_per_s": 5})
    assert em == ERROR_MODEL and isinstance(em.heating_quanta_per_s, float)


def test_unknown_key_is_refused_by_name():
    with pytest.raises(InputError, match="'T2'"):
        ErrorModel.from_dict({"T2": 0.05})
    with pytest.raises(InputError, match="'CAMPAIGN_KEYS'"):
        ErrorModel.from_dict({"CAMPAIGN_KEYS": ()})


@pytest.mark.parametrize("key, near", [("T2", "T2_s"), ("power_jitter", "power_jitter_db"),
                                       ("seed", None), ("parity_phases", None),
                                       ("table_points", None), ("colour", None)])
def test_a_key_that_is_no_error_model_key_is_refused_in_one_line(key, near):
    """The fields of the simulator and of the parity scans are no error-model keys."""
    with pytest.raises(InputError) as exc:
        ErrorModel.from_dict({key: 1})
    msg = str(exc.value)
    assert "\n" not in msg and f"unknown error_model key '{key}'" in msg
    assert ("did you mean" not in msg) if near is None else f"did you mean '{near}'?" in msg
    assert "T2_s" in msg


@pytest.mark.parametrize("key, value", [("p_prep", "0.003"), ("p_det", -1e-5), ("p_det", 1.5),
                                        ("T2_s", 0.0), ("nbar", float("nan")), ("seed", 1.5),
                                        ("parity_phases", 0), ("power_jitter_db", True),
                                        ("T2_s", 10 ** 400), ("nbar", -(10 ** 400))])
def test_bad_value_is_refused_by_name(key, value):
    with pytest.raises(InputError, match=f"'{key}'"):
        if key in ErrorModel.CAMPAIGN_KEYS:
            ErrorModel.from_dict({key: value})
        else:
            ErrorModel(**{key: value})


def test_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        ERROR_MODEL.T2_s = 1.0


def test_analysis_phases():
    ph = ERROR_MODEL.analysis_phases()
    assert ph.shape == (16,)
    assert np.array_equal(ph, np.arange(16) * 2 * np.pi / 16)


def test_gate_engine_defaults_are_the_error_model():
    from dpdfit.models import gate_sim
    from dpdfit.models.gate_sim import setting
    assert gate_sim.T2_S is ERROR_MODEL.T2_s
    assert gate_sim.NDOT is ERROR_MODEL.heating_quanta_per_s
    assert gate_sim.P_PREP is ERROR_MODEL.p_prep
    assert gate_sim.P_DET is ERROR_MODEL.p_det
    for fn in (gate_sim.simulate_setting, gate_sim.populations, gate_sim.parity_even,
               gate_sim.setting_branches):
        p = inspect.signature(fn).parameters
        assert p["nbar"].default == ERROR_MODEL.nbar
        assert p["T2"].default is ERROR_MODEL.T2_s
        assert p["ndot"].default is ERROR_MODEL.heating_quanta_per_s
        if "p_prep" in p:
            assert p["p_prep"].default is ERROR_MODEL.p_prep
        if "p_det" in p:
            assert p["p_det"].default is ERROR_MODEL.p_det
    assert np.array_equal(setting._analysis_phases(None), ERROR_MODEL.analysis_phases())


def test_diagnosis_defaults_are_the_error_model():
    from dpdfit.analyses.diagnosis.model.gates import observe
    from dpdfit.analyses.diagnosis.observables import campaign
    assert campaign.DEFAULT_ERROR_MODEL == ERROR_MODEL.campaign_dict()
    assert ErrorModel.from_dict(campaign.DEFAULT_ERROR_MODEL) == ERROR_MODEL
    assert np.array_equal(observe.PHASES, ERROR_MODEL.analysis_phases())


def test_simulator_and_alignment_defaults_are_the_error_model():
    from dpdfit.fits import alignment
    from dpdfit.simulation.campaign import DEFAULT_SEED, CampaignConfig
    cfg = CampaignConfig()
    assert DEFAULT_SEED is ERROR_MODEL.seed and cfg.seed is ERROR_MODEL.seed
    assert (cfg.nbar, cfg.T2, cfg.ndot, cfg.p_prep, cfg.p_det, cfg.power_jitter_db,
            cfg.xi0_rel_err, cfg.lut_points) == (
        ERROR_MODEL.nbar, ERROR_MODEL.T2_s, ERROR_MODEL.heating_quanta_per_s,
        ERROR_MODEL.p_prep, ERROR_MODEL.p_det, ERROR_MODEL.power_jitter_db,
        ERROR_MODEL.xi0_rel_err, ERROR_MODEL.table_points)
    for fn in (alignment.align, alignment.xi0_band):
        assert inspect.signature(fn).parameters["sigma_db"].default is ERROR_MODEL.power_jitter_db
