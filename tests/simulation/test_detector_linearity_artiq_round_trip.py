"""A detector linearity characterisation through ARTIQ results files and back: a schedule's
``detector_linearity`` rows recorded by the simulator standing in for the lab
(``dpdfit write-artiq-results --schedule``), imported by the shipped ndscan mapping's
``[[detector_linearity]]`` (``dpdfit import``) into ``detector_linearity.csv``, every
reading as recorded; a campaign's own table the same way; an impossible attenuation in a
mapping refused in one line."""

from __future__ import annotations

import dataclasses
import json
import tomllib

import numpy as np
import pandas as pd
import pytest

from dpdfit.cli.main import main
from dpdfit.errors import InputError
from dpdfit.recordings.detector_linearity import linearity_drives
from dpdfit.recordings.mapping import read_mapping
from dpdfit.recordings.schedule import read_schedule, write_schedule
from dpdfit.simulation.artiq_results import MAPPINGS
from dpdfit.simulation.campaign import CampaignConfig, simulate_campaign
from dpdfit.simulation.further_recordings import schedule_measurements
from dpdfit.simulation.ndscan_lab import linearity_runs
from dpdfit.simulation.recorded_schedule import record_further
from tests.helpers.artiq_round_trip import cli_ok as _cli, own_table_round_trip
from tests.helpers.standin import SMALL

pytest.importorskip("h5py")


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """The small campaign without gate recordings (fast), and a schedule of an amplitude
    run (the new recordings' mapping then a whole campaign's: ``dpdfit import`` takes it)
    and two linearity recordings of 6 drives."""
    root = tmp_path_factory.mktemp("linearity_artiq")
    folder = root / "campaign"
    simulate_campaign(folder, config=SMALL, progress=False, include_gates=False)
    grid = np.round(np.linspace(0.0, 1.0, SMALL.cal_points), 10)
    rows = [{"kind": "amplitude_run", "repeat": 1, "point": i, "A": a, "lab_s": 1.0}
            for i, a in enumerate(grid)]
    rows += [{"kind": "detector_linearity", "repeat": r, "point": i, "A": a, "lab_s": 20.0,
              "attenuation_db": 10.0} for r in (1, 2) for i, a in enumerate(linearity_drives(6))]
    schedule = root / "schedule.csv"
    write_schedule(pd.DataFrame(rows), schedule)
    return folder, schedule


def test_scheduled_linearity_recorded_as_artiq_results_imports_as_recorded(campaign, tmp_path,
                                                                           capsys):
    folder, schedule = campaign
    assert read_schedule(schedule).columns[-1] == "attenuation_db"
    lab, imported = tmp_path / "lab", tmp_path / "imported"
    _cli(["write-artiq-results", folder, lab, "--schedule", schedule], capsys)
    files = sorted(p.name for p in lab.glob("results/*/*/*.h5"))
    assert [f.split("-", 1)[1] for f in files] == ["AmplitudeCalibration.h5"] + [
        "DetectorLinearity.h5"] * 2
    mapping = read_mapping(lab / "mapping.toml")
    assert [s.table for s in mapping.sources] == ["calibration_amplitude", "detector_linearity"]
    _cli(["import", lab / "mapping.toml", "-o", imported], capsys)
    cfg = CampaignConfig.from_truth(json.loads((folder / "truth.json").read_text()))
    want = record_further(cfg, schedule_measurements(read_schedule(schedule))).tables[
        "detector_linearity"]
    got = pd.read_csv(imported / "detector_linearity.csv")
    assert len(got) == 12
    pd.testing.assert_frame_equal(got[list(want.columns)], want, check_exact=True,
                                  check_dtype=False)
    from dpdfit.recordings.campaign_folder import CampaignFolder
    assert len(CampaignFolder(imported).detector_linearity) == 12


def test_a_campaigns_own_table_written_whole_and_imported_back(tmp_path, capsys):
    cfg = dataclasses.replace(SMALL, detector_linearity_points=8)
    own_table_round_trip(cfg, tmp_path, capsys, "detector_linearity", "DetectorLinearity",
                         check_dtype=False)


def test_the_mapping_written_for_a_campaign_without_it_has_no_source(tmp_path):
    from dpdfit.simulation.artiq_results import write_ndscan_campaign
    from tests.helpers.bundled_data import CAMPAIGN
    assert "detector_linearity" in tomllib.loads((MAPPINGS / "ndscan_campaign.toml").read_text())
    text = write_ndscan_campaign(CAMPAIGN, tmp_path / "lab").read_text()
    assert "detector_linearity" not in tomllib.loads(text)
    assert "DetectorLinearity" not in text


def test_an_impossible_attenuation_in_a_mapping_is_one_line(tmp_path, capsys):
    text = (MAPPINGS / "ndscan_campaign.toml").read_text()
    old = 'attenuation_db = { argument = "attenuation_db" }'
    assert old in text
    path = tmp_path / "mapping.toml"
    path.write_text(text.replace(old, "attenuation_db = 0.0"))
    with pytest.raises(InputError) as exc:
        read_mapping(path)
    msg = str(exc.value)
    assert len(msg.splitlines()) == 1
    assert "detector_linearity[1].columns.attenuation_db" in msg and "> 0 dB" in msg
    assert main(["import", str(path), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "> 0 dB" in err, err
    assert not (tmp_path / "out").exists()


def test_runs_split_where_a_lab_would_begin_a_run():
    rows = pd.DataFrame({"A": [0.2, 0.6, 1.0, 0.2, 0.6, 0.2, 0.6],
                         "attenuation_db": [10, 10, 10, 10, 10, 20, 20]})
    assert [r.index.tolist() for r in linearity_runs(rows)] == [[0, 1, 2], [3, 4], [5, 6]]
    assert linearity_runs(rows.iloc[:0]) == []
