"""A sideband thermometry through ARTIQ results files and back: a schedule's
``thermometry`` rows recorded by the simulator standing in for the lab (``dpdfit
write-artiq-results --schedule``), imported by the shipped ndscan mapping's
``[[thermometry]]`` (``dpdfit import``) into ``thermometry.csv``, every count as
recorded; a campaign's own ``thermometry.csv`` the same way; a mapping naming a sideband
that does not exist refused in one line."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pandas as pd
import pytest

from dpdfit.cli.main import main
from dpdfit.errors import InputError
from dpdfit.models.sideband_thermometry import THERMOMETRY_WAITS_US
from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.recordings.mapping import read_mapping
from dpdfit.recordings.schedule import read_schedule, write_schedule
from dpdfit.simulation.artiq_results import MAPPINGS
from dpdfit.simulation.campaign import CampaignConfig, simulate_campaign
from dpdfit.simulation.further_recordings import schedule_measurements
from dpdfit.simulation.ndscan_thermometry import sideband_code, thermometry_runs
from dpdfit.simulation.recorded_schedule import record_further
from tests.helpers.artiq_round_trip import cli_ok as _cli, own_table_round_trip
from tests.helpers.standin import SMALL

pytest.importorskip("h5py")

#: the thermometry recordings of the schedule: (repeat, shots)
_RECORDINGS = [(1, 120), (2, 120)]
_POINTS = [(w, s) for w in THERMOMETRY_WAITS_US for s in ("red", "blue")]


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """The small campaign without gate recordings (fast), and a schedule of an amplitude
    run (so that the new recordings' mapping is a whole campaign's) and two thermometry
    recordings."""
    root = tmp_path_factory.mktemp("thermo_artiq")
    folder = root / "campaign"
    simulate_campaign(folder, config=SMALL, progress=False, include_gates=False)
    grid = np.round(np.linspace(0.0, 1.0, SMALL.cal_points), 10)
    rows = [{"kind": "amplitude_run", "repeat": 1, "point": i, "A": a, "lab_s": 1.0}
            for i, a in enumerate(grid)]
    rows += [{"kind": "thermometry", "repeat": r, "point": i, "A": 0.0, "shots": n,
              "wait_us": w, "sideband": s, "lab_s": 0.5}
             for r, n in _RECORDINGS for i, (w, s) in enumerate(_POINTS)]
    schedule = root / "schedule.csv"
    write_schedule(pd.DataFrame(rows), schedule)
    return folder, schedule


def test_scheduled_thermometry_recorded_as_artiq_results_imports_as_recorded(campaign,
                                                                             tmp_path, capsys):
    folder, schedule = campaign
    lab, imported = tmp_path / "lab", tmp_path / "imported"
    sched = read_schedule(schedule)
    thermo = sched[sched["kind"] == "thermometry"]
    assert thermo["sideband"].tolist()[:2] == ["red", "blue"]
    assert (sched.loc[sched["kind"] != "thermometry", "sideband"] == "").all()
    printed = _cli(["write-artiq-results", folder, lab, "--schedule", schedule], capsys)
    assert f"{2 * len(_POINTS)} thermometry rows" in printed
    files = sorted(p.name for p in lab.glob("results/*/*/*.h5"))
    assert [f.split("-", 1)[1] for f in files] == ["AmplitudeCalibration.h5"] + [
        "SidebandThermometry.h5"] * 2
    mapping = read_mapping(lab / "mapping.toml")
    assert [s.table for s in mapping.sources] == ["calibration_amplitude", "thermometry"]
    _cli(["import", lab / "mapping.toml", "-o", imported], capsys)
    cfg = CampaignConfig.from_truth(json.loads((folder / "truth.json").read_text()))
    want = record_further(cfg, schedule_measurements(read_schedule(schedule))).tables[
        "thermometry"]
    got = pd.read_csv(imported / "thermometry.csv")
    assert got["sideband"].tolist() == [s for _ in _RECORDINGS for _, s in _POINTS]
    pd.testing.assert_frame_equal(got[list(want.columns)], want, check_exact=True,
                                  check_dtype=False)
    pooled = CampaignFolder(imported).thermometry
    assert pooled["shots"].tolist() == [240.0] * len(_POINTS)


def test_a_campaigns_own_thermometry_written_whole_and_imported_back(tmp_path, capsys):
    cfg = dataclasses.replace(SMALL, thermometry_shots=200)
    own_table_round_trip(cfg, tmp_path, capsys, "thermometry", "SidebandThermometry",
                         check_dtype=False)


def test_the_mapping_written_for_a_campaign_without_it_has_no_thermometry_source(tmp_path):
    from dpdfit.simulation.artiq_results import write_ndscan_campaign
    from tests.helpers.bundled_data import CAMPAIGN
    import tomllib
    assert "thermometry" in tomllib.loads((MAPPINGS / "ndscan_campaign.toml").read_text())
    text = write_ndscan_campaign(CAMPAIGN, tmp_path / "lab").read_text()
    assert "thermometry" not in tomllib.loads(text) and "SidebandThermometry" not in text
    assert text.endswith('xi0_err_khz = { channel = "xi0_err" }\n')


def _mapping(tmp_path, line: str):
    text = (MAPPINGS / "ndscan_campaign.toml").read_text()
    old = 'sideband = { axis = "sideband", labels = { 0 = "red", 1 = "blue" } }'
    assert old in text
    path = tmp_path / "mapping.toml"
    path.write_text(text.replace(old, line))
    return path


@pytest.mark.parametrize("line, words", [
    ('sideband = { axis = "sideband", labels = { 0 = "red", 1 = "green" } }',
     'sideband "green" does not exist'),
    ('sideband = "carrier"', 'sideband "carrier" does not exist'),
])
def test_a_sideband_that_does_not_exist_is_one_line(tmp_path, capsys, line, words):
    path = _mapping(tmp_path, line)
    with pytest.raises(InputError) as exc:
        read_mapping(path)
    msg = str(exc.value)
    assert len(msg.splitlines()) == 1 and words in msg and "thermometry[1]" in msg
    assert main(["import", str(path), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "does not exist" in err, err
    assert not (tmp_path / "out").exists()


def test_a_negative_constant_wait_is_refused(tmp_path):
    text = (MAPPINGS / "ndscan_campaign.toml").read_text()
    path = tmp_path / "mapping.toml"
    path.write_text(text.replace('wait_us = { axis = "wait" }', "wait_us = -5"))
    with pytest.raises(InputError, match="negative"):
        read_mapping(path)


def test_thermometry_runs_split_where_a_lab_would_begin_a_run():
    rows = pd.DataFrame({"wait_us": [0, 0, 10, 0, 0, 10], "sideband": ["red", "blue"] * 3,
                         "shots": [5, 5, 5, 5, 7, 7]})
    assert sideband_code(["red", "Blue ", "blue"]).tolist() == [0, 1, 1]
    assert [r.index.tolist() for r in thermometry_runs(rows)] == [[0, 1, 2], [3], [4, 5]]
    assert thermometry_runs(rows.iloc[:0]) == []
