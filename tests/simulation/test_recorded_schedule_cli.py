"""``dpdfit write-artiq-results CAMPAIGN OUT --schedule S.csv``: the simulator records a
schedule, only the new recordings are written; bad input is one line, exit 2, nothing
written."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pandas as pd
import pytest

from dpdfit.cli.main import main
from dpdfit.recordings.campaign_import import import_campaign
from dpdfit.recordings.mapping import read_mapping
from dpdfit.recordings.schedule import read_schedule, write_schedule
from dpdfit.simulation.campaign import CampaignConfig, simulate_campaign
from dpdfit.simulation.further_recordings import schedule_measurements
from dpdfit.simulation.recorded_schedule import record_further
from tests.helpers.standin import SMALL

pytest.importorskip("h5py")


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """A campaign of calibrations and spectra only (fast), and a schedule for it: one
    amplitude run on the campaign's grid, and spectra at a new and a recorded amplitude."""
    root = tmp_path_factory.mktemp("standin_cli")
    folder = root / "campaign"
    simulate_campaign(folder, config=SMALL, progress=False, include_gates=False)
    grid = np.round(np.linspace(0.0, 1.0, SMALL.cal_points), 10)
    rows = [{"kind": "amplitude_run", "repeat": 1, "point": i, "A": a, "lab_s": 1.0}
            for i, a in enumerate(grid)]
    rows += [{"kind": "spectra", "repeat": 1, "point": k, "A": a, "dpd": d, "lab_s": 5.0}
             for k, (a, d) in enumerate((a, d) for a in (0.3, 0.6) for d in (0, 1))]
    schedule = root / "schedule.csv"
    write_schedule(pd.DataFrame(rows), schedule)
    return folder, schedule


def test_records_the_schedule_and_writes_only_the_new_files(campaign, tmp_path, capsys):
    folder, schedule = campaign
    before = sorted(p.name for p in folder.iterdir())
    out = tmp_path / "lab"
    assert main(["write-artiq-results", str(folder), str(out), "--schedule",
                 str(schedule)]) == 0
    printed = capsys.readouterr().out
    assert "51 calibration_amplitude" in printed and "48 spectra" in printed
    assert sorted(p.name for p in folder.iterdir()) == before       # campaign untouched
    assert len(list(out.glob("results/*/*/*.h5"))) == 3              # one run, two spectra
    imported = import_campaign(read_mapping(out / "mapping.toml", partial=True), progress=False)
    cfg = CampaignConfig.from_truth(json.loads((folder / "truth.json").read_text()))
    want = record_further(cfg, schedule_measurements(read_schedule(schedule))).tables
    assert set(imported.tables) == set(want) == {"calibration_amplitude", "spectra"}
    amp = imported.tables["calibration_amplitude"].drop(columns=["source_file", "source_rid"])
    pd.testing.assert_frame_equal(amp, want["calibration_amplitude"], check_exact=True,
                                  check_dtype=False)
    assert set(amp["run"]) == {"R006"}
    sp = imported.tables["spectra"].drop(columns=["source_file", "source_rid"])
    keys = ["A", "dpd", "sideband", "n"]
    pd.testing.assert_frame_equal(sp.sort_values(keys, kind="stable").reset_index(drop=True),
                                  want["spectra"].sort_values(keys, kind="stable")
                                  .reset_index(drop=True), check_exact=True, check_dtype=False)


def _refused(args, capsys, match: str) -> str:
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and match in err, err
    return err


def test_bad_input_one_line_nothing_written(campaign, tmp_path, capsys):
    folder, schedule = campaign
    out = tmp_path / "lab"
    run = ["write-artiq-results", str(folder), str(out), "--schedule"]
    # a campaign without truth.json (a lab's own) cannot stand in for the lab
    lab_campaign = tmp_path / "lab_campaign"
    shutil.copytree(folder, lab_campaign)
    (lab_campaign / "truth.json").unlink()
    _refused(["write-artiq-results", str(lab_campaign), str(out), "--schedule", str(schedule)],
             capsys, "has no truth.json: only a simulated campaign can stand in for the lab")
    # a schedule edited into nonsense
    bad = tmp_path / "bad.csv"
    bad.write_text(schedule.read_text().replace("spectra,1,0,0.3,0,", "spectra,1,0,1.3,0,", 1))
    _refused(run + [str(bad)], capsys, "amplitude 1.3 is outside (0, 1]")
    unknown = tmp_path / "unknown.csv"
    unknown.write_text(schedule.read_text().replace("amplitude_run", "warp_run", 1))
    _refused(run + [str(unknown)], capsys, "unknown kind 'warp_run'")
    # an output folder inside the campaign, or one that exists
    _refused(["write-artiq-results", str(folder), str(folder / "new"), "--schedule",
              str(schedule)], capsys, "inside the campaign folder")
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "x").write_text("")
    _refused(["write-artiq-results", str(folder), str(tmp_path / "full"), "--schedule",
              str(schedule)], capsys, "exists and is not empty")
    _refused(run + [str(schedule), "--shape", "per-shot"], capsys, "ndscan layout only")
    assert not out.exists() and not (folder / "new").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.csv", "full", "lab_campaign",
                                                          "unknown.csv"]
