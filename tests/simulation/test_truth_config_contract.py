"""The contract of a campaign's truth.json config (``CampaignConfig.from_truth``): every value
of its kind and range, refused in one line naming the file and the key otherwise; every
config the simulator writes accepted as written."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import tests.helpers.prop_mutations  # noqa: F401  (the fixed hypothesis profile)
from dpdfit.core.defaults import MAX_TRACE_SAMPLES
from dpdfit.errors import InputError
from dpdfit.simulation import harness as H
from dpdfit.simulation.campaign import CampaignConfig
from dpdfit.simulation.campaign.config import TRUTH_CONTRACT
from dpdfit.simulation.campaign.simulate import _jsonable_config, _truth_json
from dpdfit.simulation.further_recordings import default_menu, extend_config
from dpdfit.simulation.harness_campaign import harness_config
from tests.helpers.bundled_data import CAMPAIGN
from tests.helpers.further_campaign import FURTHER
from tests.helpers.further_campaign import small_config as further_small_config
from tests.helpers.standin import SMALL
from dpdfit.simulation.truth_edits import (REPLACEMENTS, config_of_every_kind, edited, path_text,
                                       single_field_edits, value_paths)


def written(cfg: CampaignConfig) -> dict:
    """The ``config`` of the truth.json the simulator writes for ``cfg`` (10 digits)."""
    return json.loads(_truth_json({"config": _jsonable_config(cfg)}))["config"]


def _every_kind() -> dict:
    config, effects = config_of_every_kind()
    return written(config.with_effects(effects))


#: the configs edited: the bundled campaign's truth.json as it is on disk, and one holding a
#: value of every kind (effects named, two injected, further recordings of every kind)
CONFIGS = {"bundled": json.loads((CAMPAIGN / "truth.json").read_text())["config"],
           "every kind": _every_kind()}


def refusal_or_config(config: dict, path: tuple):
    """``from_truth`` of an edited config: the config, or the one-line refusal, checked
    to name truth.json and the edited key (its field; a relation names every key)."""
    try:
        return CampaignConfig.from_truth(config)
    except InputError as exc:
        line = str(exc)
    assert line.isprintable() and "\n" not in line, line
    assert line.startswith("truth.json: config key"), line
    field = path[0]
    named = (f"config key '{field}" in line if line.startswith("truth.json: config key ")
             else f"'{field}'" in line)
    assert named, (path_text(path), line)
    return line


def test_the_contract_covers_every_field_and_its_default():
    names = {f.name for f in dataclasses.fields(CampaignConfig)}
    assert set(TRUTH_CONTRACT) == names
    assert CampaignConfig.from_truth(written(CampaignConfig())) == CampaignConfig()


def test_every_single_field_edit_is_refused_in_one_line_or_a_config():
    for name, config in CONFIGS.items():
        refused = 0
        for path, value, edit in single_field_edits(config):
            got = refusal_or_config(edit, path)
            if isinstance(got, str):
                refused += 1
                # a value of the wrong kind or out of range is named by its own path
                if value in ("text", "null", "object", "nested list", "NaN"):
                    assert f"config key '{path_text(path)}" in got, (path, value, got)
            else:
                # accepted: written again, the config reads back as itself
                assert CampaignConfig.from_truth(written(got)) == got
        assert refused > 0.9 * len(value_paths(config)) * len(REPLACEMENTS), name


#: a JSON value as Python's reader gives it, NaN and Infinity included
JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers(-10 ** 40, 10 ** 40)
    | st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner,
                                                               max_size=3),
    max_leaves=8)


@given(st.sampled_from(sorted(CONFIGS)), st.data(), JSON_VALUES | st.sampled_from(
    list(REPLACEMENTS.values())))
def test_any_value_in_any_place_is_refused_in_one_line_or_a_valid_config(name, data, value):
    config = CONFIGS[name]
    path = data.draw(st.sampled_from(value_paths(config)), label="path")
    got = refusal_or_config(edited(config, path, value), path)
    if not isinstance(got, str):
        assert CampaignConfig.from_truth(written(got)) == got


@pytest.mark.parametrize(("path", "value", "line"), [
    (("n_samples",), -1, "config key 'n_samples' must be an integer in [1, 2^24], not -1"),
    (("n_samples",), 2 ** 40, "config key 'n_samples' must be an integer in [1, 2^24], not "
                              "1099511627776"),
    (("scan_shots", 0, 1), "ten", "config key 'scan_shots[0][1]' must be an integer in "
                                  "[1, 1000000000], not 'ten'"),
    (("scan_shots", 1), 625, "config key 'scan_shots[1]' must be a list [population shots, "
                             "parity shots], not 625"),
    (("photodiode", "sigma_0"), None, "config key 'photodiode.sigma_0' must be a number in "
                                      "[1e-12, 1e+09], not null"),
    (("heterodyne_phase", "leak"), [1], "config key 'heterodyne_phase.leak' must be a number "
                                        "in [0, 1], not a list of 1 item"),
    (("trace_amplitudes", 0), float("nan"), "config key 'trace_amplitudes[0]' must be a "
                                            "number in (0, 1], not NaN"),
    (("A_corr_mean",), 1e308, "config key 'A_corr_mean' must be a number in [0.02, 2/pi), "
                              "not 1e+308"),
    (("cal_points",), True, "config key 'cal_points' must be an integer in [2, 10001], "
                            "not true"),
    (("spectra_mode",), "fast", "config key 'spectra_mode' must be one of 'traces', "
                                "'direct', not 'fast'"),
    (("start",), "yesterday", "config key 'start' must be a date and time in ISO 8601"),
    (("harmonics_gate",), [0, 1], "config key 'harmonics_gate' lacks 2"),
])
def test_a_bad_value_is_named_by_its_key_and_range(path, value, line):
    with pytest.raises(InputError) as exc:
        CampaignConfig.from_truth(edited(CONFIGS["bundled"], path, value), file="camp/truth.json")
    assert str(exc.value).startswith("camp/truth.json: " + line), str(exc.value)


def test_injected_effects_and_further_recordings_are_checked_item_by_item():
    every = CONFIGS["every kind"]
    cases = [
        (("injected", 0, 0), "warp", "config key 'injected[0][0]' must be a registered effect"),
        (("injected", 0, 1, 0, 0), "p_warp", "config key 'injected[0][1][0][0]' must be a "
                                              "parameter of spam_offset (p_extra, p_spec, "
                                              "p_flip), not 'p_warp'"),
        (("injected", 1, 1, 0, 1), float("inf"), "config key 'injected[1][1][0][1]' must be "
                                                 "a finite number, not Infinity"),
        (("injected", 0, 1, 0, 1), -1, "config key 'injected[0][1][0][1]' must be a number "
                                       "in [0, 1], not -1"),
        (("effects", "spam_offset"), "x", "config key 'effects.spam_offset' must be a finite number, not 'x'"),
        (("further", 2, 0), "warp_scan", "config key 'further[2][0]' must be one of "
                                         "'amplitude_run', 'phase_run', 'scan', 'time_scan'"),
        (("further", 4, 4), 10 ** 40, "config key 'further[4][4]' must be an integer in "
                                      "[2, 10001], not an integer of more than 30 digits"),
    ]
    for path, value, line in cases:
        with pytest.raises(InputError) as exc:
            CampaignConfig.from_truth(edited(every, path, value))
        assert str(exc.value).startswith("truth.json: " + line), str(exc.value)
    # an effect named twice, or a parameter given twice
    twice = edited(every, ("injected", 0, 1, 1), ["p_extra", 0.001])
    with pytest.raises(InputError, match=r"'injected\[0\]\[1\]\[1\]' gives the parameter "
                                         "p_extra of spam_offset again"):
        CampaignConfig.from_truth(twice)
    with pytest.raises(InputError, match=r"'effects.warp' is not NAME or NAME.PARAM"):
        CampaignConfig.from_truth(edited(every, ("effects",), {"warp": 1.0}))


@pytest.mark.parametrize(("changes", "keys"), [
    ({"runs_after_recordings": 34}, "'runs_after_recordings' and 'n_amp_runs'"),
    ({"time_scan_A": 0.45}, "'time_scan_A' and 'gate_amplitudes'"),
    ({"cal_points": 9}, "'cal_points' and 'order'"),
    ({"A_corr_sigma": 0.03}, "'A_corr_mean', 'A_corr_sigma' and 'table_drift'"),
    ({"nu": 1.84e6 + 1.0}, "'nu' and 'xi0_spec'"),
    ({"n_samples": 40_000}, "'fs', 'xi0_spec', 'n_samples'"),
    ({"f_det": 1e6}, "'fs', 'xi0_spec', 'n_samples', 'f_det'"),
    ({"n_amp_runs": 60_000, "cal_points": 201}, "'n_amp_runs', 'n_phase_runs', 'cal_points'"),
])
def test_values_that_cannot_be_together_are_refused_naming_every_key(changes, keys):
    config = {**CONFIGS["bundled"], **changes}
    with pytest.raises(InputError) as exc:
        CampaignConfig.from_truth(config)
    line = str(exc.value)
    assert line.startswith("truth.json: config keys ") and keys in line, line
    assert "\n" not in line


def test_retired_and_unknown_keys_keep_their_refusals():
    bundled = CONFIGS["bundled"]
    with pytest.raises(InputError, match="config key 'memory_tau' is not 0"):
        CampaignConfig.from_truth({**bundled, "memory_tau": True})
    with pytest.raises(InputError, match="unknown config key '\\\\x1b\\[31m"):
        CampaignConfig.from_truth({**bundled, "\x1b[31m": 1})
    with pytest.raises(InputError, match="its config is not a JSON object"):
        CampaignConfig.from_truth({"config": [1, 2]})


def _harness_configs() -> list:
    """Every kind of harness campaign's config: catalog, pairs, triples and each form of
    each effect (left-out forms, mixed), as the harness injects them."""
    jobs = H.plan(per_effect=2, nulls=1, pairs=2, triples=2, leave_one_form_out=True,
                  per_form=1, pairs_left_out=2, triples_left_out=2)
    return [harness_config(job["seed"]).inject(job["effects"]) for job in jobs]


def _further_configs() -> list:
    """Configs with further recordings: each kind, and the default menu's."""
    out, cfg = [], further_small_config()
    for measurement in FURTHER:
        cfg = extend_config(cfg, measurement)
        out.append(cfg)
    rng = np.random.default_rng(5)
    for measurement in default_menu(rng, SMALL):
        out.append(extend_config(SMALL, measurement))
    return out


def test_every_config_the_simulator_writes_is_accepted_as_written():
    configs = [CampaignConfig(), SMALL, further_small_config(), *_harness_configs(),
               *_further_configs(),
               # benchmarks/scale.py's largest campaign: 64 x the bundled one's runs and grid
               CampaignConfig(n_amp_runs=34 * 64, n_phase_runs=6 * 64, spectra_mode="direct",
                              trace_amplitudes=tuple(np.round(np.linspace(0.05, 1.0, 38 * 64 + 1),
                                                              4)), bundled_traces=()),
               # simulate-campaign's options and every effect's strength
               CampaignConfig(stale_days=10.0, table_drift=0.03),
               *(CampaignConfig().with_effects({name: 0.01}) for name in H.concealed_effects())]
    assert len(configs) > 40
    for cfg in configs:
        text = written(cfg)
        back = CampaignConfig.from_truth(text)
        assert written(back) == text


def test_a_bound_at_its_end_is_taken_and_beyond_it_refused():
    bundled = CONFIGS["bundled"]
    cfg = CampaignConfig.from_truth({**bundled, "n_samples": MAX_TRACE_SAMPLES,
                                     "stale_days": 3650, "p_det": 1})
    assert (cfg.n_samples, cfg.stale_days, cfg.p_det) == (MAX_TRACE_SAMPLES, 3650.0, 1.0)
    for key, beyond in (("n_samples", MAX_TRACE_SAMPLES + 1), ("stale_days", 3650.5),
                        ("p_det", 1.0000001), ("T2", math.inf)):
        with pytest.raises(InputError, match=f"config key '{key}' must be"):
            CampaignConfig.from_truth({**bundled, key: beyond})
