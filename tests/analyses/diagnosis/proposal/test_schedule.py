"""The proposal as a schedule: the rows a lab records, and back to the measurement.

A schedule made from a proposal must hold exactly the points the proposal means (the
campaign's grids, phases and times, the repeats, the lab time), come back unchanged
through its file, turn back into the same measurement for the simulator, and refuse a
file edited into nonsense in one line naming the column and row.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings, strategies as st

from dpdfit.analyses.diagnosis.proposal.schedule import proposal_schedule
from dpdfit.core.defaults import ERROR_MODEL, LAB_TIMES
from dpdfit.errors import InputError
from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.recordings.schedule import SCHEDULE_COLUMNS, read_schedule, write_schedule
from dpdfit.simulation.further_recordings import schedule_measurements
from tests.helpers.bundled_data import CAMPAIGN

PROPOSALS = [
    {"what": "amplitude_run", "settings": {"runs": 2}, "lab_seconds": 600.0},
    {"what": "phase_run", "settings": {"runs": 1}, "lab_seconds": 400.0},
    {"what": "spectra", "settings": {"amplitudes": [0.3, 0.3, 0.85], "dpd": [0, 1]},
     "lab_seconds": 360.0},
    {"what": "populations", "settings": {"A": 0.5, "dpd": 1, "shots": 625, "scans": 3},
     "lab_seconds": 18.75},
    {"what": "parity", "settings": {"A": 0.6, "dpd": 0, "shots": 10000, "scans": 2},
     "lab_seconds": 200.0},
    {"what": "time_scan", "settings": {"A": 0.5, "dpd": 1, "shots": 625, "points": 24,
                                       "scans": 2}, "lab_seconds": 300.0},
]
#: the proposals above are costed with the default lab times: each row's own time
ROW_SECONDS = {"amplitude_run": LAB_TIMES.amplitude_run_s / 201,
               "phase_run": LAB_TIMES.phase_run_s / 201,
               "spectra": LAB_TIMES.spectrum_trace_s,
               "populations": 625 * LAB_TIMES.shot_s,
               "parity": 625 * LAB_TIMES.shot_s,
               "time_scan": 625 * LAB_TIMES.shot_s}


@pytest.fixture(scope="module")
def camp():
    return CampaignFolder(CAMPAIGN)


@pytest.mark.parametrize("proposal", PROPOSALS, ids=lambda p: p["what"])
def test_schedule_lists_every_point_of_every_repeat(proposal, camp):
    df = proposal_schedule(proposal, camp)
    st_ = proposal["settings"]
    assert list(df.columns) == list(SCHEDULE_COLUMNS)
    assert set(df["kind"]) == {proposal["what"]}
    assert df["lab_s"].sum() == pytest.approx(proposal["lab_seconds"], rel=1e-12)
    np.testing.assert_allclose(df["lab_s"], ROW_SECONDS[proposal["what"]], rtol=1e-12)
    assert not df.duplicated(["repeat", "point"]).any()
    what = proposal["what"]
    if what == "amplitude_run":
        runs = camp.amplitude_runs
        last = runs.loc[runs["run"] == runs["run"].iloc[-1], "A"].to_numpy(float)
        for r in (1, 2):
            np.testing.assert_array_equal(df.loc[df["repeat"] == r, "A"], last)
        assert df["dpd"].isna().all() and df["shots"].isna().all()
    elif what == "spectra":
        # 0.3 twice: repeats 1 and 2; 0.85 once; each with both flags
        assert sorted(map(tuple, df[["repeat", "A", "dpd"]].to_numpy().tolist())) == [
            (1, 0.3, 0), (1, 0.3, 1), (1, 0.85, 0), (1, 0.85, 1), (2, 0.3, 0), (2, 0.3, 1)]
    elif what == "populations":
        assert len(df) == 3 and (df["shots"] == 625).all() and (df["A"] == 0.5).all()
    elif what == "parity":
        rec = camp.parity
        phases = np.unique(rec.loc[(rec["A"] == 0.6) & (rec["dpd"] == 0), "phase_rad"])
        for r in (1, 2):
            np.testing.assert_array_equal(df.loc[df["repeat"] == r, "phase_rad"], phases)
        # the proposal counts parity shots over every phase
        assert (df["shots"] == st_["shots"] / ERROR_MODEL.parity_phases).all()
    elif what == "time_scan":
        ts = camp.time_scans
        times = np.unique(ts.loc[(ts["A"] == 0.5) & (ts["dpd"] == 1), "t_us"])
        # the times after the start, as many as the proposal's points (t = 0 is not fitted)
        assert times[0] == 0 and times.size == st_["points"] + 1
        for r in (1, 2):
            np.testing.assert_array_equal(df.loc[df["repeat"] == r, "t_us"], times[1:])


@pytest.mark.parametrize("proposal", PROPOSALS, ids=lambda p: p["what"])
def test_schedule_file_and_measurement_give_the_proposal_back(proposal, camp, tmp_path):
    df = proposal_schedule(proposal, camp)
    path = tmp_path / "schedule.csv"
    write_schedule(df, path)
    back = read_schedule(path)
    pd.testing.assert_frame_equal(back, df, check_dtype=False, rtol=1e-9)
    [m] = schedule_measurements(back)
    want = dict(proposal["settings"])
    if proposal["what"] == "spectra":
        want["amplitudes"] = sorted(want["amplitudes"])
    for k in ("scans", "runs"):
        if k in m["settings"] and k not in want:
            want[k] = 1
    assert m == {"what": proposal["what"], "settings": want}


def test_no_proposal_is_refused_with_its_reason(camp):
    with pytest.raises(InputError, match="nothing to schedule: the verdict stands"):
        proposal_schedule({"what": None, "reason": "the verdict stands"}, camp)


GOOD = ("kind,repeat,point,A,dpd,shots,phase_rad,t_us,lab_s\n"
        "populations,1,0,0.5,1,625,,,6.25\n"
        "time_scan,1,0,0.5,0,625,,0,6.25\n"
        "time_scan,1,1,0.5,0,625,,15.2,6.25\n")


@pytest.mark.parametrize("old,new,column,row", [
    ("populations,1,0,0.5,1,625", "populations,1,0,0.5,1,-625", "shots", 1),
    ("populations,1,0,0.5,1,625", "populations,1,0,0.5,1,62.5", "shots", 1),
    ("populations,1", "cpmg,1", "kind", 1),             # (ramsey is a kind now)
    ("populations,1,0,0.5", "populations,1,0,1.5", "A", 1),
    ("populations,1,0,0.5,1", "populations,1,0,0.5,2", "dpd", 1),
    ("time_scan,1,1,0.5,0,625,,15.2", "time_scan,1,0,0.5,0,625,,15.2", "point", 3),
    ("time_scan,1,1,0.5,0,625", "time_scan,1,1,0.5,0,500", "shots", 3),
    ("time_scan,1,1,0.5,0,625,,15.2", "time_scan,1,1,0.5,0,625,,", "t_us", 3),
    ("time_scan,1,1,0.5,0,625,,15.2", "time_scan,1,1,0.5,0,625,,-15.2", "t_us", 3),
    ("populations,1,0", "populations,0,0", "repeat", 1),
])
def test_nonsense_schedule_refused_in_one_line(tmp_path, old, new, column, row):
    path = tmp_path / "schedule.csv"
    path.write_text(GOOD.replace(old, new, 1))
    with pytest.raises(InputError) as exc:
        read_schedule(path)
    msg = str(exc.value)
    assert "\n" not in msg and str(path) in msg
    assert f"column '{column}'" in msg or f"column {column}" in msg, msg
    assert f"row {row}" in msg, msg


def test_a_good_schedule_is_read(tmp_path):
    path = tmp_path / "schedule.csv"
    path.write_text(GOOD)
    df = read_schedule(path)
    assert df["kind"].tolist() == ["populations", "time_scan", "time_scan"]
    assert df["t_us"].tolist()[1:] == [0.0, 15.2] and np.isnan(df["phase_rad"]).all()


@settings(max_examples=40, deadline=None)
@given(what=st.sampled_from(["populations", "parity", "spectra"]),
       scans=st.integers(1, 40), shots=st.integers(1, 5000),
       A=st.sampled_from([0.4, 0.5, 0.6, 0.7, 0.8]), dpd=st.integers(0, 1),
       seconds=st.floats(0, 3e4))
def test_any_proposal_round_trips(tmp_path_factory, what, scans, shots, A, dpd, seconds):
    camp = CampaignFolder(CAMPAIGN)
    if what == "spectra":
        prop = {"what": what, "settings": {"amplitudes": [A] * scans, "dpd": [0, 1]}}
    else:
        shots = shots * (ERROR_MODEL.parity_phases if what == "parity" else 1)
        prop = {"what": what, "settings": {"A": A, "dpd": dpd, "shots": shots,
                                           "scans": scans}}
    prop["lab_seconds"] = seconds
    df = proposal_schedule(prop, camp)
    path = tmp_path_factory.mktemp("s") / "schedule.csv"
    write_schedule(df, path)
    [m] = schedule_measurements(read_schedule(path))
    assert m == {"what": what, "settings": prop["settings"]}


@pytest.mark.parametrize("where", ["a folder", "inside the campaign", "an input"])
def test_diagnose_schedule_path_refused_before_the_diagnosis(where, tmp_path, capsys,
                                                             monkeypatch):
    """One line, exit 2, before any fit (the diagnosis is never called), nothing written."""
    import shutil

    import dpdfit.analyses.diagnosis.diagnose as diagnose_module
    from dpdfit.cli.main import main
    camp = tmp_path / "campaign"
    shutil.copytree(CAMPAIGN, camp)
    path = {"a folder": tmp_path, "inside the campaign": camp / "schedule.csv",
            "an input": camp}[where]
    # the command imports diagnose() when it runs: replaced in its module
    monkeypatch.setattr(diagnose_module, "diagnose", lambda *a, **k: pytest.fail("diagnosed"))
    before = sorted(p.name for p in camp.iterdir())
    assert main(["diagnose", str(camp), "--schedule", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("dpdfit: error:"), err
    assert sorted(p.name for p in camp.iterdir()) == before
