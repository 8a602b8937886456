"""One more recording, round trip, for every ``what`` of the menu, through the command line.

A proposal becomes a schedule (``proposal_schedule``, the table ``diagnose --schedule``
writes), the simulator records the schedule as ARTIQ results files (``dpdfit
write-artiq-results --schedule``), ``dpdfit add`` merges them into a copy of the
campaign, and ``dpdfit diagnose --compare`` diagnoses the copy.  The copy must be
exactly the campaign the simulator records with the schedule's measurements added
(every table, every column; the campaign's own rows unchanged and first; the
simulator under the campaign's ``truth.json``, which the stand-in records under), and the
diagnosis must have read the new rows.
"""

from __future__ import annotations

import json

import pandas as pd
import pytest

from dpdfit.analyses.diagnosis.proposal.schedule import proposal_schedule
from dpdfit.cli.main import main
from dpdfit.recordings.schedule import read_schedule, write_schedule
from dpdfit.simulation.campaign import CampaignConfig, simulate_campaign
from dpdfit.simulation.further_recordings import (MEASUREMENTS, extend_config,
                                                  schedule_measurements)
from tests.helpers.built_once import built_once
from tests.helpers.standin import SMALL

pytest.importorskip("h5py")

#: one proposal of every ``what``, as the diagnosis writes them (parity shots over every
#: phase), at the small campaign's settings
PROPOSALS = {
    "amplitude_run": {"what": "amplitude_run", "settings": {"runs": 2}, "lab_seconds": 600},
    "phase_run": {"what": "phase_run", "settings": {"runs": 1}, "lab_seconds": 400},
    "spectra": {"what": "spectra", "settings": {"amplitudes": [0.3, 0.6], "dpd": [0, 1]},
                "lab_seconds": 240},
    "populations": {"what": "populations", "lab_seconds": 9.0,
                    "settings": {"A": 0.6, "dpd": 0, "shots": 300, "scans": 3}},
    "parity": {"what": "parity", "lab_seconds": 64.0,
               "settings": {"A": 0.4, "dpd": 1, "shots": 3200, "scans": 2}},
    "time_scan": {"what": "time_scan", "lab_seconds": 36.0,
                  "settings": {"A": 0.6, "dpd": 1, "shots": 300, "points": 6, "scans": 2}},
    "spam": {"what": "spam", "lab_seconds": 4.0,
             "settings": {"shots": 500, "states": ["00", "11"], "scans": 2}},
    "pulse_response": {"what": "pulse_response", "lab_seconds": 120.0,
                       "settings": {"A": 0.6, "scans": 2}},
    "ramsey": {"what": "ramsey", "lab_seconds": 100.0,
               "settings": {"shots": 120, "points": 20, "max_wait_us": 75000.0}},
    "detector_linearity": {"what": "detector_linearity", "lab_seconds": 2 * 160.0,
                           "settings": {"points": 10, "attenuation_db": 10.0, "scans": 2}},
    "thermometry": {"what": "thermometry", "lab_seconds": 16.0,
                    "settings": {"shots": 200, "scans": 1,
                                 "waits_us": [0.0, 250.0, 500.0, 1000.0, 2000.0, 4000.0,
                                              7000.0, 10000.0], "sidebands": ["red", "blue"]}},
}
#: the columns that order a table's rows among themselves (repeats keep their order)
KEYS = {"calibration_amplitude": ["run"], "calibration_phase": ["run"],
        "spectra": ["A", "dpd", "sideband", "n"], "populations": ["A", "dpd", "scan"],
        "parity": ["A", "dpd", "scan", "phase_rad"], "gate_rates": ["A", "dpd"],
        "time_scans": ["A", "dpd", "t_us"], "spam": ["prepared"],
        "pulse_response": ["run", "t_us"], "ramsey": ["sequence", "wait_us"],
        "detector_linearity": ["A"],
        "thermometry": ["wait_us", "sideband"]}


def test_every_what_of_the_menu_has_a_round_trip():
    assert set(PROPOSALS) == set(MEASUREMENTS)


def _cli(*args, capsys) -> str:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    assert code == 0, err
    return out


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """The small campaign, with its truth.json: the simulator stands in for the lab.
    Built once per test run (the six cases may run on both xdist workers)."""
    def build(root):
        simulate_campaign(root / "campaign", config=SMALL, progress=False)
        return root
    return built_once(tmp_path_factory, "round_trip_lab", build)


@pytest.fixture(scope="module")
def before(lab, tmp_path_factory):
    """The campaign's diagnosis, as ``dpdfit diagnose --json`` writes it (once per run)."""
    from dpdfit.analyses.diagnosis.diagnose import diagnose
    from dpdfit.core.jsonable import to_jsonable

    def build(folder):
        d = to_jsonable(diagnose(lab / "campaign", progress=False).to_dict())
        path = folder / "before.json"
        path.write_text(json.dumps(d))
        return path, d
    return built_once(tmp_path_factory, "round_trip_before", build)


def _same_added_rows(campaign, merged, simulated) -> None:
    """Every table: the merged campaign is the campaign's rows, unchanged and first, then
    exactly the rows the simulator's recording added (every column of the simulator's,
    exact values; the simulator appends its further recordings too)."""
    for path in sorted(simulated.glob("*.csv")):
        if path.name == "traces.csv":
            continue                  # raw traces are not ARTIQ datasets (not imported)
        want = pd.read_csv(path)
        old = pd.read_csv(campaign / path.name) if (campaign / path.name).exists() else \
            want.iloc[:0]
        got = pd.read_csv(merged / path.name)[list(want.columns)]
        assert len(got) == len(want), path.name
        pd.testing.assert_frame_equal(got.iloc[:len(old)], old[list(want.columns)],
                                      check_exact=True, obj=path.name)
        pd.testing.assert_frame_equal(_ordered(got.iloc[len(old):], path.stem),
                                      _ordered(want.iloc[len(old):], path.stem),
                                      check_exact=True, obj=f"{path.name}, added rows")


def _ordered(df: pd.DataFrame, table: str) -> pd.DataFrame:
    """Rows by their keys, repeats of one key in the order they were recorded (pandas
    sorts on several columns without keeping ties in order: the repeat is a key too)."""
    keys = KEYS[table]
    df = df.assign(_repeat=df.groupby(keys, sort=False).cumcount())
    return df.sort_values(keys + ["_repeat"]).drop(columns="_repeat").reset_index(drop=True)


@pytest.mark.slow
@pytest.mark.parametrize("what", sorted(PROPOSALS))
def test_schedule_record_add_diagnose(what, lab, before, tmp_path, capsys):
    before_json, d0 = before
    work = tmp_path
    schedule = proposal_schedule(PROPOSALS[what], lab / "campaign")
    write_schedule(schedule, work / "schedule.csv")
    _cli("write-artiq-results", lab / "campaign", work / "lab", "--schedule",
         work / "schedule.csv", capsys=capsys)
    _cli("add", lab / "campaign", work / "lab" / "mapping.toml", "-o", work / "plus",
         capsys=capsys)

    # the added rows are those the simulator records with the schedule's measurements added
    # to the campaign's truth (truth.json: what the stand-in recorded under)
    cfg = CampaignConfig.from_truth(json.loads((lab / "campaign" / "truth.json").read_text()))
    for m in schedule_measurements(read_schedule(work / "schedule.csv")):
        cfg = extend_config(cfg, m)
    simulate_campaign(work / "simulated", config=cfg, progress=False)
    _same_added_rows(lab / "campaign", work / "plus", work / "simulated")

    out = json.loads(_cli("diagnose", work / "plus", "--compare", before_json, "--json",
                          "--no-progress", capsys=capsys))
    comparison = out["comparison"]
    assert comparison["campaign_after"] == str(work / "plus")
    assert comparison["verdict_before"] == d0["verdict"]
    if what == "amplitude_run":          # two more runs after the recordings
        assert len(out["runs_after_recordings"]) == len(d0["runs_after_recordings"]) + 2
    # the new rows are in the fit (a further phase run too: taken after the recordings,
    # it is data): the baseline sees other recordings
    assert out["baseline_chi2"] != pytest.approx(d0["baseline_chi2"], rel=1e-9)
