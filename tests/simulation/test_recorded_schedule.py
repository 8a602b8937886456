"""The simulator standing in for the lab: a campaign's config back from its truth.json, the
rows further recordings add (simulated alone, equal to the whole extended campaign's),
and those rows through ARTIQ results files and ``dpdfit import`` back, bit for bit."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pandas as pd
import pytest

from dpdfit.errors import InputError
from dpdfit.recordings.campaign_import import import_campaign
from dpdfit.recordings.mapping import read_mapping
from dpdfit.simulation.campaign import CampaignConfig, simulate_campaign
from dpdfit.simulation.campaign.simulate import _jsonable_config, _rounded
from dpdfit.simulation.further_recordings import MEASUREMENTS
from dpdfit.simulation.recorded_artiq import (campaign_files_end, read_campaign_tables,
                                              write_recorded_results)
from dpdfit.simulation.recorded_schedule import (CHARACTERISATION_TABLES, TABLES,
                                                 check_replayed, difference_rows,
                                                 record_further, simulated_tables)
from tests.helpers.bundled_data import CAMPAIGN
from tests.helpers.standin import SMALL

pytest.importorskip("h5py")

#: one measurement of every ``what``: a repeated run, spectra at a new amplitude and at a
#: recorded one, populations at the first setting (no later setting replayed), parity at
#: a new amplitude (its gate rate, populations and parity), a time scan at the last one,
#: a SPAM characterisation recorded twice and a Ramsey scan (a campaign without spam.csv
#: and ramsey.csv: new tables)
PER_WHAT = {
    "amplitude_run": {"what": "amplitude_run", "settings": {"runs": 2}},
    "phase_run": {"what": "phase_run", "settings": {"runs": 1}},
    "spectra": {"what": "spectra", "settings": {"amplitudes": [0.3, 0.6], "dpd": [0, 1]}},
    "populations": {"what": "populations",
                    "settings": {"A": 0.4, "dpd": 0, "shots": 400, "scans": 2}},
    "parity": {"what": "parity", "settings": {"A": 0.5, "dpd": 1, "shots": 3200}},
    "time_scan": {"what": "time_scan",
                  "settings": {"A": 0.6, "dpd": 1, "shots": 100, "points": 4, "scans": 2}},
    "spam": {"what": "spam", "settings": {"shots": 500, "scans": 2}},
    "pulse_response": {"what": "pulse_response", "settings": {"A": 0.6}},
    "ramsey": {"what": "ramsey", "settings": {"shots": 120}},
    "detector_linearity": {"what": "detector_linearity", "settings": {"points": 5, "scans": 2}},
    "thermometry": {"what": "thermometry", "settings": {"shots": 150, "scans": 2}},
}
#: the tables each kind simulates whole in the long way (the others cannot change)
_WHOLE = {"amplitude_run": dict(include_spectra=False, include_gates=False),
          "phase_run": dict(include_spectra=False, include_gates=False),
          "spectra": dict(include_gates=False),
          "spam": dict(include_spectra=False, include_gates=False),
          "pulse_response": dict(include_spectra=False, include_gates=False),
          "ramsey": dict(include_spectra=False, include_gates=False),
          "detector_linearity": dict(include_spectra=False, include_gates=False),
          "thermometry": dict(include_spectra=False, include_gates=False)}
#: the columns that give a row's place among repeats (a stable sort keeps the repeats' order)
_KEYS = {"calibration_amplitude": ["run"], "calibration_phase": ["run"],
         "spectra": ["A", "dpd", "sideband", "n"], "populations": ["A", "dpd", "scan"],
         "parity": ["A", "dpd", "scan", "phase_rad"], "gate_rates": ["A", "dpd"],
         "time_scans": ["A", "dpd"], "spam": ["prepared"], "pulse_response": ["run", "t_us"],
         "ramsey": ["sequence", "wait_us"], "detector_linearity": ["A"],
         "thermometry": ["wait_us", "sideband"]}


def test_every_what_is_covered():
    assert set(PER_WHAT) == set(MEASUREMENTS)


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """The small campaign on disk, its tables as read back, and as simulated in memory
    from the config its truth.json gives back."""
    folder = tmp_path_factory.mktemp("standin") / "campaign"
    simulate_campaign(folder, config=SMALL, progress=False)
    tables, meta = read_campaign_tables(folder)
    cfg = CampaignConfig.from_truth(json.loads((folder / "truth.json").read_text()))
    return folder, tables, meta, simulated_tables(cfg)


@pytest.fixture(scope="module")
def calibrations(tmp_path_factory):
    """The small campaign without its gate recordings (fast): truth.json, calibrations,
    spectra."""
    folder = tmp_path_factory.mktemp("standin") / "calibrations"
    simulate_campaign(folder, config=SMALL, progress=False, include_gates=False)
    return folder, *read_campaign_tables(folder)


def as_recorded(imported: pd.DataFrame, original: pd.DataFrame, table: str) -> pd.DataFrame:
    """Imported new rows as the campaign numbers them: ``scan`` (1, 2, ... per setting in
    the import, the schedule's repeats) continued after the campaign's scans there."""
    df = imported.drop(columns=["source_file", "source_rid"])
    if table in ("populations", "parity"):
        last = original.groupby(["A", "dpd"])["scan"].max()
        df["scan"] = [s + int(last.get((a, d), 0))
                      for a, d, s in zip(df["A"], df["dpd"], df["scan"])]
    return df


def same_rows(got: pd.DataFrame, want: pd.DataFrame, table: str) -> None:
    """Equal as rows (every column, exact values), in the order of their keys."""
    keys = _KEYS[table]
    got = got[list(want.columns)].sort_values(keys, kind="stable").reset_index(drop=True)
    want = want.sort_values(keys, kind="stable").reset_index(drop=True)
    pd.testing.assert_frame_equal(got, want, check_exact=True, check_dtype=False)


def test_config_back_from_the_bundled_truth():
    truth = json.loads((CAMPAIGN / "truth.json").read_text())
    cfg = CampaignConfig.from_truth(truth)
    assert cfg == CampaignConfig()              # the bundled campaign is the default config
    assert _jsonable_config(cfg) == truth["config"]


def test_config_back_from_a_harness_style_truth(calibrations):
    folder, *_ = calibrations
    truth = json.loads((folder / "truth.json").read_text())
    cfg = CampaignConfig.from_truth(truth)
    # values of few digits come back exactly (simulate_campaign(config=...) records the
    # injection, not the effects' names; nothing is injected twice)
    assert cfg == dataclasses.replace(SMALL, effects={})
    assert cfg.injected == SMALL.injected and cfg.further == (("phase_run",),)
    assert _jsonable_config(cfg) == truth["config"]
    # drawn values of 17 digits: truth.json keeps 10, and writing the config again gives
    # truth.json's config exactly (that is what "equal" can mean for them)
    values = {"tau": 1e-7 / 3, "f_off": np.pi * 1e6}
    drawn = SMALL.inject({"aom_memory": values})
    text = json.loads(json.dumps(_rounded(_jsonable_config(drawn))))
    back = CampaignConfig.from_truth(text)
    assert _rounded(_jsonable_config(back)) == text
    (name, items), = back.injected[-1:]
    assert name == "aom_memory"
    got = {k: v for k, v in items if k in values}
    assert got == pytest.approx(values, rel=5e-10) and got != values


@pytest.mark.slow
def test_config_back_simulates_the_campaign(campaign):
    folder, _, _, again = campaign                 # simulated from from_truth's config
    for t in TABLES:
        text = again[t].to_csv(index=False, float_format="%.10g", lineterminator="\n")
        assert text == (folder / f"{t}.csv").read_text(), t


def test_truth_refused_in_one_line():
    base = _jsonable_config(SMALL)
    with pytest.raises(InputError, match="unknown config key 'warp'"):
        CampaignConfig.from_truth({**base, "warp": 1})
    with pytest.raises(InputError, match="'memory_tau' is not 0"):
        CampaignConfig.from_truth({**base, "memory_tau": 5e-8})
    with pytest.raises(InputError, match="'photodiode' is not a PhotodiodeNoise"):
        CampaignConfig.from_truth({**base, "photodiode": {"gain": 1}})


@pytest.mark.slow
@pytest.mark.parametrize("what", sorted(PER_WHAT))
def test_new_rows_are_the_extended_campaigns_and_import_back(what, campaign, tmp_path):
    folder, tables, meta, simulated = campaign
    m = PER_WHAT[what]
    rec = record_further(SMALL, [m], original=tables)
    kw = _WHOLE.get(what, {})
    before = {t: simulated[t] for t in simulated if kw.get("include_spectra", True)
              or t != "spectra"}
    before = {t: df for t, df in before.items() if kw.get("include_gates", True)
              or t in ("calibration_amplitude", "calibration_phase", "spectra")}
    want = difference_rows(SMALL, [m], before=before, **kw)
    assert set(rec.tables) == set(want) and want
    for t in want:
        pd.testing.assert_frame_equal(rec.tables[t], want[t], check_exact=True)
    mapping = write_recorded_results(rec.tables, tables, meta, tmp_path / "lab")
    imported = import_campaign(read_mapping(mapping, partial=True), progress=False)
    assert set(imported.tables) == set(want)
    for t in want:
        same_rows(as_recorded(imported.tables[t], tables.get(t), t), want[t], t)


@pytest.mark.slow
def test_every_what_at_once_numbered_after_the_campaign(campaign, tmp_path):
    folder, tables, meta, _ = campaign
    rec = record_further(SMALL, list(PER_WHAT.values()), original=tables)
    assert set(rec.tables) == set(TABLES) | set(CHARACTERISATION_TABLES)
    mapping = write_recorded_results(rec.tables, tables, meta, tmp_path / "lab")
    imported = import_campaign(read_mapping(mapping, partial=True), progress=False)
    for t in rec.tables:
        same_rows(as_recorded(imported.tables[t], tables.get(t), t), rec.tables[t], t)
    # amplitude runs continue the campaign's labels, through their rid
    amp = imported.tables["calibration_amplitude"]
    assert list(dict.fromkeys(amp["run"])) == ["R006", "R007"]
    assert set(amp["source_rid"]) == {6, 7}
    assert list(dict.fromkeys(imported.tables["calibration_phase"]["run"])) == ["P004"]
    # every other file after every rid and start time of the campaign's own files
    last_rid, last_time = campaign_files_end(tables, meta)
    others = [p for p in imported.meta["imported"]["sources"]
              if p["tables"] != ["calibration_amplitude"]]
    assert min(p["rid"] for p in others) == last_rid + 1
    gate_files = [p for p in others if set(p["tables"]) & {"spectra", "populations", "parity",
                                                           "time_scans", "gate_rates"}]
    assert min(pd.Timestamp(p["start_time"]).timestamp() for p in gate_files) > last_time
    # the campaign's constants: dpdfit add sees the same campaign
    want = {k: v for k, v in meta.items() if k not in ("spectra_recorded", "gates_recorded")}
    got = {k: v for k, v in imported.meta.items()
           if k not in ("spectra_recorded", "gates_recorded", "imported")}
    assert got == want


def test_campaign_files_end_counts_the_ndscan_set(tmp_path):
    """The rids continued after are those write_ndscan_campaign gives the campaign."""
    from dpdfit.simulation.artiq_results import write_ndscan_campaign
    tables, meta = read_campaign_tables(CAMPAIGN)
    last_rid, last_time = campaign_files_end(tables, meta)
    write_ndscan_campaign(CAMPAIGN, tmp_path / "lab")
    files = sorted((tmp_path / "lab").glob("results/*/*/*.h5"))
    assert last_rid == len(files) == max(int(f.name.split("-")[0]) for f in files)


def test_edited_campaign_refused(calibrations):
    _, tables, _ = calibrations
    edited = {t: df.copy() for t, df in tables.items()}
    edited["calibration_amplitude"].loc[7, "power"] *= 1 + 1e-4
    with pytest.raises(InputError, match=r"calibration_amplitude.csv row 8, column power"):
        record_further(SMALL, [PER_WHAT["amplitude_run"]], original=edited)
    short = {**tables, "calibration_phase": tables["calibration_phase"].iloc[:-51]}
    with pytest.raises(InputError, match="only an unedited simulated campaign"):
        record_further(SMALL, [PER_WHAT["phase_run"]], original=short)
    check_replayed({"spectra": tables["spectra"]}, tables)           # its own rows pass


@pytest.mark.slow
def test_added_to_a_copy_the_rows_are_the_simulators(campaign, tmp_path):
    """Through ``dpdfit add``: the merged campaign's new rows are the simulator's new rows
    exactly, scan labels continued by the merge as the simulator continues them."""
    from dpdfit.recordings.campaign_add import add_recordings
    folder, tables, meta, _ = campaign
    rec = record_further(SMALL, list(PER_WHAT.values()), original=tables)
    mapping = write_recorded_results(rec.tables, tables, meta, tmp_path / "lab")
    out = add_recordings(folder, mapping, progress=False).write(tmp_path / "merged")
    assert set(rec.tables) == set(TABLES) | set(CHARACTERISATION_TABLES)
    assert not any((folder / f"{t}.csv").exists() for t in CHARACTERISATION_TABLES)
    for t in rec.tables:
        merged = pd.read_csv(out / f"{t}.csv", dtype={"prepared": str})
        old = (pd.read_csv(folder / f"{t}.csv") if (folder / f"{t}.csv").exists() else
               rec.tables[t].iloc[:0])
        pd.testing.assert_frame_equal(merged[list(old.columns)].iloc[:len(old)], old,
                                      check_exact=True)
        new = merged.iloc[len(old):].drop(columns=["source_file", "source_rid"])
        same_rows(new, rec.tables[t], t)
