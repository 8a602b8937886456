"""A schedule says what the proposal assumed, so that a lab does not have to guess.

Each row's own lab time (summing to the proposal's), when it is taken (calibration runs
paced as the campaign's own runs were, everything else back to back), a time scan of as
many points as the proposal counts, parity shots split over the campaign's own phases,
and the tone repeatability a trace was predicted with.  The campaigns are small ones
written for the purpose (:mod:`tests.helpers.schedule_campaign`).
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from dpdfit.analyses.diagnosis.proposal.schedule import DAY_S, proposal_schedule
from dpdfit.core.defaults import ERROR_MODEL, LAB_TIMES, LabTimes
from dpdfit.errors import InputError
from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.recordings.schedule import (OPTIONAL_COLUMNS, SCHEDULE_COLUMNS, read_schedule,
                                        write_schedule)
from dpdfit.simulation.further_recordings import schedule_measurements
from tests.helpers.schedule_campaign import (GRID, PARITY_SETTING, TIME_SCAN_SETTING,
                                             write_lab_campaign)


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """8 parity phases (not the default 16), a time scan of 31 times from t = 0, amplitude
    runs 2, 2 and 2.5 days apart, phase runs 30 minutes apart."""
    assert ERROR_MODEL.parity_phases != 8
    return CampaignFolder(write_lab_campaign(tmp_path_factory.mktemp("lab") / "campaign"))


def _round_trip(df, tmp_path):
    path = tmp_path / "schedule.csv"
    write_schedule(df, path)
    back = read_schedule(path)
    pd.testing.assert_frame_equal(back, df, check_dtype=False, rtol=1e-12)
    return back


# ----------------------------------------------------------------- time scans
def test_a_time_scan_has_as_many_rows_as_the_proposal_has_points(lab, tmp_path):
    """The campaign's scan has 31 times from t = 0; the diagnosis fits (and the proposal
    counts) the 30 after the start: 30 rows per scan, not 31."""
    A, d = TIME_SCAN_SETTING
    prop = {"what": "time_scan", "settings": {"A": A, "dpd": d, "shots": 400, "points": 30,
                                              "scans": 3}, "lab_seconds": 3 * 30 * 4.0}
    df = proposal_schedule(prop, lab)
    assert df.groupby("repeat").size().tolist() == [30, 30, 30]
    assert (df["t_us"] > 0).all()
    np.testing.assert_array_equal(df.loc[df["repeat"] == 1, "t_us"],
                                  np.linspace(0.0, 150.0, 31)[1:])
    [m] = schedule_measurements(_round_trip(df, tmp_path))
    assert m == {"what": "time_scan", "settings": prop["settings"]}


@pytest.mark.parametrize("points", [31, 29])
def test_a_time_scan_of_other_points_than_the_campaigns_is_refused(lab, points):
    A, d = TIME_SCAN_SETTING
    prop = {"what": "time_scan", "settings": {"A": A, "dpd": d, "shots": 400,
                                              "points": points}}
    with pytest.raises(InputError, match=f"has {points} points, the campaign's has 30 times"):
        proposal_schedule(prop, lab)


def test_an_older_schedule_listing_t0_gives_the_same_measurement(lab, tmp_path):
    """A schedule written before listed t = 0 too: the simulator reads the same points."""
    A, d = TIME_SCAN_SETTING
    rows = [{"kind": "time_scan", "repeat": 1, "point": i, "A": A, "dpd": d, "shots": 400,
             "t_us": t} for i, t in enumerate(np.linspace(0.0, 150.0, 31))]
    path = tmp_path / "old.csv"
    pd.DataFrame(rows).to_csv(path, index=False)
    [m] = schedule_measurements(read_schedule(path))
    assert m["settings"]["points"] == 30


# ----------------------------------------------------------------- parity
def test_parity_shots_are_split_over_the_campaigns_own_phases(lab, tmp_path):
    """8 phases recorded (campaign.json: parity_phases 8): shots per phase times phases
    is the proposal's shots (the default 16 would have halved them)."""
    A, d = PARITY_SETTING
    prop = {"what": "parity", "settings": {"A": A, "dpd": d, "shots": 10000, "scans": 2}}
    df = proposal_schedule(prop, lab)
    for _, scan in df.groupby("repeat"):
        assert len(scan) == 8
        assert int(scan["shots"].iloc[0]) * len(scan) == 10000
    np.testing.assert_allclose(df.loc[df["repeat"] == 1, "phase_rad"],
                               np.arange(8) * 2 * np.pi / 8)
    [m] = schedule_measurements(_round_trip(df, tmp_path))
    assert m["settings"]["shots"] == 10000


def test_parity_at_a_new_setting_takes_the_campaigns_number_of_phases(lab):
    prop = {"what": "parity", "settings": {"A": 0.45, "dpd": 1, "shots": 8 * 300}}
    df = proposal_schedule(prop, lab)
    np.testing.assert_allclose(df["phase_rad"], np.arange(8) * 2 * np.pi / 8)
    assert (df["shots"] == 300).all()


@pytest.mark.parametrize("value", [0, 2.5, "8", True])
def test_a_campaigns_parity_phases_that_is_not_a_count_is_refused(tmp_path, value):
    folder = write_lab_campaign(tmp_path / "campaign")
    meta = json.loads((folder / "campaign.json").read_text())
    (folder / "campaign.json").write_text(json.dumps({**meta, "parity_phases": value}))
    prop = {"what": "parity", "settings": {"A": 0.45, "dpd": 1, "shots": 2400}}
    with pytest.raises(InputError) as exc:
        proposal_schedule(prop, CampaignFolder(folder))
    assert "parity_phases" in str(exc.value) and "campaign.json" in str(exc.value)


# ----------------------------------------------------------------- lab time and pacing
def test_calibration_runs_are_paced_as_the_campaigns_runs_were(lab, tmp_path):
    """Amplitude runs 2, 2 and 2.5 days apart: the median gap, two days, between runs,
    each at the start of its day's session, its points back to back."""
    prop = {"what": "amplitude_run", "settings": {"runs": 3},
            "lab_seconds": 3 * LAB_TIMES.amplitude_run_s}
    df = _round_trip(proposal_schedule(prop, lab), tmp_path)
    each = LAB_TIMES.amplitude_run_s / GRID.size
    np.testing.assert_allclose(df["lab_s"], each, rtol=1e-12)
    assert df["lab_s"].sum() == pytest.approx(prop["lab_seconds"], rel=1e-12)
    for r, run in df.groupby("repeat"):
        assert (run["day"] == 2 * (r - 1)).all()
        np.testing.assert_allclose(run["start_s"], np.arange(GRID.size) * each, atol=1e-9)


def test_phase_runs_minutes_apart_stay_in_one_session(lab):
    prop = {"what": "phase_run", "settings": {"runs": 3}}
    df = proposal_schedule(prop, lab)
    firsts = df[df["point"] == 0]
    assert (df["day"] == 0).all()
    np.testing.assert_allclose(firsts["start_s"], [0.0, 1800.0, 3600.0])
    # without a lab_seconds, each row costs what the lab times say
    assert df["lab_s"].sum() == pytest.approx(3 * LAB_TIMES.phase_run_s)


def test_runs_without_timestamps_are_taken_one_a_day(tmp_path):
    camp = CampaignFolder(write_lab_campaign(tmp_path / "campaign", timestamps=False))
    df = proposal_schedule({"what": "amplitude_run", "settings": {"runs": 3}}, camp)
    assert df.loc[df["point"] == 0, "day"].tolist() == [0, 1, 2]
    assert (df.loc[df["point"] == 0, "start_s"] == 0).all()


def test_scans_are_taken_back_to_back_in_the_next_session(lab):
    A, d = PARITY_SETTING
    prop = {"what": "parity", "settings": {"A": A, "dpd": d, "shots": 8 * 500, "scans": 3},
            "lab_seconds": 3 * 8 * 500 * LAB_TIMES.shot_s}
    df = proposal_schedule(prop, lab)
    assert (df["day"] == 0).all()
    np.testing.assert_allclose(df["lab_s"], 500 * LAB_TIMES.shot_s, rtol=1e-12)
    np.testing.assert_allclose(df["start_s"], np.arange(len(df)) * 500 * LAB_TIMES.shot_s,
                               atol=1e-9)
    assert df["start_s"].max() < DAY_S


def test_lab_seconds_of_other_lab_times_are_shared_in_proportion(lab):
    """A proposal made with a lab's own times: the rows keep their proportions and sum to
    its lab_seconds; given those times, each row's is its own."""
    slow = LabTimes(shot_s=0.025)
    A, d = TIME_SCAN_SETTING
    prop = {"what": "time_scan", "settings": {"A": A, "dpd": d, "shots": 200, "points": 30},
            "lab_seconds": 30 * 200 * slow.shot_s}
    for times in (None, slow):
        df = proposal_schedule(prop, lab, lab=times)
        np.testing.assert_allclose(df["lab_s"], 200 * slow.shot_s, rtol=1e-12)
        assert df["lab_s"].sum() == pytest.approx(prop["lab_seconds"], rel=1e-12)


# ----------------------------------------------------------------- spectra
def test_spectra_rows_carry_the_tone_repeatability_assumed(lab, tmp_path):
    prop = {"what": "spectra", "settings": {"amplitudes": [0.3, 0.3, 0.85], "dpd": [0, 1],
                                            "tone_sd_db": 0.04},
            "lab_seconds": 6 * LAB_TIMES.spectrum_trace_s}
    df = _round_trip(proposal_schedule(prop, lab), tmp_path)
    assert (df["tone_sd_db"] == 0.04).all()
    np.testing.assert_allclose(df["start_s"], np.arange(6) * LAB_TIMES.spectrum_trace_s)
    [m] = schedule_measurements(df)
    assert m == {"what": "spectra", "settings": {"amplitudes": [0.3, 0.3, 0.85],
                                                 "dpd": [0, 1], "tone_sd_db": 0.04}}


# ----------------------------------------------------------------- the file
OLD = ("kind,repeat,point,A,dpd,shots,phase_rad,t_us,lab_s\n"
       "populations,1,0,0.5,1,625,,,6.25\n"
       "spectra,1,0,0.5,0,,,,60\n")


def test_a_schedule_without_the_new_columns_is_still_read(tmp_path):
    path = tmp_path / "schedule.csv"
    path.write_text(OLD)
    df = read_schedule(path)
    assert list(df.columns) == list(SCHEDULE_COLUMNS)
    assert SCHEDULE_COLUMNS[:9] == ("kind", "repeat", "point", "A", "dpd", "shots",
                                    "phase_rad", "t_us", "lab_s")
    assert set(OPTIONAL_COLUMNS) >= {"day", "start_s", "tone_sd_db"}
    assert df["day"].isna().all() and df["start_s"].isna().all()
    assert df["tone_sd_db"].isna().all()


NEW = ("kind,repeat,point,A,dpd,shots,phase_rad,t_us,lab_s,day,start_s,tone_sd_db\n"
       "populations,1,0,0.5,1,625,,,6.25,0,0,\n"
       "spectra,1,0,0.5,0,,,,60,2,6.25,0.04\n")


@pytest.mark.parametrize("old,new,column,row", [
    ("6.25,0,0,", "6.25,-1,0,", "day", 1),
    ("6.25,0,0,", "6.25,0.5,0,", "day", 1),
    ("6.25,0,0,", "6.25,0,-3,", "start_s", 1),
    ("6.25,0,0,", "6.25,0,soon,", "start_s", 1),
    ("60,2,6.25,0.04", "60,2,6.25,0", "tone_sd_db", 2),
    ("60,2,6.25,0.04", "60,2,6.25,inf", "tone_sd_db", 2),
    ("60,2,6.25,0.04", "60,2,6.25,0.04dB", "tone_sd_db", 2),
    ("60,2,6.25,0.04", "sixty,2,6.25,0.04", "lab_s", 2),
])
def test_nonsense_in_the_new_columns_is_refused_in_one_line(tmp_path, old, new, column, row):
    path = tmp_path / "schedule.csv"
    assert old in NEW
    path.write_text(NEW.replace(old, new, 1))
    with pytest.raises(InputError) as exc:
        read_schedule(path)
    msg = str(exc.value)
    assert "\n" not in msg and str(path) in msg
    assert f"column '{column}'" in msg or f"column {column}" in msg, msg
    assert f"row {row}" in msg, msg


def test_the_new_columns_are_read(tmp_path):
    path = tmp_path / "schedule.csv"
    path.write_text(NEW)
    df = read_schedule(path)
    assert df["day"].tolist() == [0, 2] and df["start_s"].tolist() == [0.0, 6.25]
    assert np.isnan(df["tone_sd_db"].iloc[0]) and df["tone_sd_db"].iloc[1] == 0.04


@pytest.mark.parametrize("prop,file", [
    ({"what": "time_scan", "settings": {"A": 0.7, "dpd": 1, "shots": 100}}, "time_scans.csv"),
    ({"what": "phase_run", "settings": {"runs": 1}}, "calibration_phase.csv"),
])
def test_what_the_campaign_lacks_is_refused_in_one_line(tmp_path, prop, file):
    folder = write_lab_campaign(tmp_path / "campaign")
    if prop["what"] == "phase_run":
        (folder / file).unlink()
    with pytest.raises(InputError) as exc:
        proposal_schedule(prop, CampaignFolder(folder))
    msg = str(exc.value)
    assert "\n" not in msg and str(folder / file) in msg, msg
