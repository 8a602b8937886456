"""A Ramsey and spin-echo scan through ARTIQ results files and back: a schedule's ``ramsey``
rows recorded by the simulator standing in for the lab (``dpdfit write-artiq-results
--schedule``), imported by the shipped ndscan mapping's ``[[ramsey]]`` (``dpdfit import``)
into ``ramsey.csv``, every count as recorded; a campaign's own ``ramsey.csv`` the same
way; a mapping naming a sequence that does not exist, or a wait below zero, refused in one
line."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pandas as pd
import pytest

from dpdfit.cli.main import main
from dpdfit.errors import InputError
from dpdfit.models.ramsey import scan_waits
from dpdfit.recordings.mapping import read_mapping
from dpdfit.recordings.schedule import read_schedule, write_schedule
from dpdfit.simulation.artiq_results import MAPPINGS
from dpdfit.simulation.campaign import CampaignConfig, simulate_campaign
from dpdfit.simulation.further_recordings import schedule_measurements
from dpdfit.simulation.ndscan_lab import ramsey_runs
from dpdfit.simulation.recorded_schedule import record_further
from tests.helpers.artiq_round_trip import cli_ok as _cli, own_table_round_trip
from tests.helpers.standin import SMALL

pytest.importorskip("h5py")

SHOTS = 150


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """The small campaign without gate recordings (fast), and a schedule of an amplitude
    run (so that the new recordings' mapping is a whole campaign's) and one Ramsey scan."""
    root = tmp_path_factory.mktemp("ramsey_artiq")
    folder = root / "campaign"
    simulate_campaign(folder, config=SMALL, progress=False, include_gates=False)
    grid = np.round(np.linspace(0.0, 1.0, SMALL.cal_points), 10)
    rows = [{"kind": "amplitude_run", "repeat": 1, "point": i, "A": a, "lab_s": 1.0}
            for i, a in enumerate(grid)]
    waits = scan_waits(SMALL.T2)
    rows += [{"kind": "ramsey", "repeat": 1, "point": j * waits.size + i, "A": 0.0,
              "shots": SHOTS, "sequence": seq, "wait_us": round(float(w) * 1e6, 3),
              "lab_s": 2.0}
             for j, seq in enumerate(("ramsey", "echo")) for i, w in enumerate(waits)]
    schedule = root / "schedule.csv"
    write_schedule(pd.DataFrame(rows), schedule)
    return folder, schedule


def test_scheduled_ramsey_recorded_as_artiq_results_imports_as_recorded(campaign, tmp_path,
                                                                       capsys):
    folder, schedule = campaign
    lab, imported = tmp_path / "lab", tmp_path / "imported"
    _cli(["write-artiq-results", folder, lab, "--schedule", schedule], capsys)
    files = sorted(p.name for p in lab.glob("results/*/*/*.h5"))
    assert [f.split("-", 1)[1] for f in files] == ["AmplitudeCalibration.h5",
                                                   "RamseyEcho.h5"]
    mapping = read_mapping(lab / "mapping.toml")
    assert [s.table for s in mapping.sources] == ["calibration_amplitude", "ramsey"]
    _cli(["import", lab / "mapping.toml", "-o", imported], capsys)
    cfg = CampaignConfig.from_truth(json.loads((folder / "truth.json").read_text()))
    want = record_further(cfg, schedule_measurements(read_schedule(schedule))).tables["ramsey"]
    got = pd.read_csv(imported / "ramsey.csv")
    assert got["sequence"].tolist() == ["ramsey"] * 20 + ["echo"] * 20
    pd.testing.assert_frame_equal(got[list(want.columns)], want, check_exact=True,
                                  check_dtype=False)
    from dpdfit.recordings.campaign_folder import CampaignFolder
    assert CampaignFolder(imported).ramsey["shots"].tolist() == [SHOTS] * 40


def test_a_campaigns_own_ramsey_written_whole_and_imported_back(tmp_path, capsys):
    cfg = dataclasses.replace(SMALL, ramsey_shots=100)
    own_table_round_trip(cfg, tmp_path, capsys, "ramsey", "RamseyEcho")


def test_the_mapping_written_for_a_campaign_without_ramsey_has_no_ramsey_source(tmp_path):
    from dpdfit.simulation.artiq_results import write_ndscan_campaign
    from tests.helpers.bundled_data import CAMPAIGN
    import tomllib
    assert "ramsey" in tomllib.loads((MAPPINGS / "ndscan_campaign.toml").read_text())
    text = write_ndscan_campaign(CAMPAIGN, tmp_path / "lab").read_text()
    assert "ramsey" not in tomllib.loads(text) and "RamseyEcho" not in text


def _ramsey_mapping(tmp_path, old: str, new_line: str):
    text = (MAPPINGS / "ndscan_campaign.toml").read_text()
    assert old in text
    path = tmp_path / "mapping.toml"
    path.write_text(text.replace(old, new_line))
    return path


@pytest.mark.parametrize("old, new, words", [
    ('sequence = { axis = "sequence", labels = { 0 = "ramsey", 1 = "echo" } }',
     'sequence = { axis = "sequence", labels = { 0 = "ramsey", 1 = "cpmg" } }',
     'sequence "cpmg" does not exist'),
    ('sequence = { axis = "sequence", labels = { 0 = "ramsey", 1 = "echo" } }',
     'sequence = "hahn"', 'sequence "hahn" does not exist'),
    ('wait_us = { axis = "wait" }', 'wait_us = -5.0', "below zero"),
])
def test_an_impossible_ramsey_mapping_is_one_line(tmp_path, capsys, old, new, words):
    path = _ramsey_mapping(tmp_path, old, new)
    with pytest.raises(InputError) as exc:
        read_mapping(path)
    msg = str(exc.value)
    assert len(msg.splitlines()) == 1 and words in msg and "ramsey[1]" in msg
    assert main(["import", str(path), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and words in err, err
    assert not (tmp_path / "out").exists()


def test_ramsey_runs_split_where_a_lab_would_begin_a_run():
    rows = pd.DataFrame({"sequence": ["ramsey", "echo", "ramsey", "ramsey", "echo"],
                         "wait_us": [0.0, 0.0, 10.0, 0.0, 0.0], "shots": [5, 5, 5, 5, 5]})
    assert [r.index.tolist() for r in ramsey_runs(rows)] == [[0, 1, 2], [3, 4]]
    assert ramsey_runs(rows.iloc[:0]) == []
