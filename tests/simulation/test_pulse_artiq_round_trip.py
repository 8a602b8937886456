"""An AOM pulse response through ARTIQ results files and back: a schedule's
``pulse_response`` rows recorded by the simulator standing in for the lab (``dpdfit
write-artiq-results --schedule``), imported by the shipped ndscan mapping's
``[[pulse_response]]`` (``dpdfit import``) into ``pulse_response.csv``, every sample as
recorded; a campaign's own trace the same way; a mapping with a constant no pulse
response holds refused in one line."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pandas as pd
import pytest

from dpdfit.cli.main import main
from dpdfit.errors import InputError
from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.recordings.mapping import read_mapping
from dpdfit.recordings.schedule import read_schedule, write_schedule
from dpdfit.simulation.artiq_results import MAPPINGS
from dpdfit.simulation.campaign import CampaignConfig, simulate_campaign
from dpdfit.simulation.further_recordings import schedule_measurements
from dpdfit.simulation.recorded_schedule import record_further
from tests.helpers.artiq_round_trip import cli_ok as _cli, own_table_round_trip
from tests.helpers.standin import SMALL

pytest.importorskip("h5py")

#: the scheduled traces: (repeat, step amplitude)
_TRACES = [(1, 0.6), (2, 0.4)]


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """The small campaign without gate recordings (fast), and a schedule of an amplitude
    run (the new recordings' mapping is then a whole campaign's) and two traces."""
    root = tmp_path_factory.mktemp("pulse_artiq")
    folder = root / "campaign"
    simulate_campaign(folder, config=SMALL, progress=False, include_gates=False)
    grid = np.round(np.linspace(0.0, 1.0, SMALL.cal_points), 10)
    rows = [{"kind": "amplitude_run", "repeat": 1, "point": i, "A": a, "lab_s": 1.0}
            for i, a in enumerate(grid)]
    rows += [{"kind": "pulse_response", "repeat": r, "point": 0, "A": A, "lab_s": 60.0}
             for r, A in _TRACES]
    schedule = root / "schedule.csv"
    write_schedule(pd.DataFrame(rows), schedule)
    return folder, schedule


def test_scheduled_traces_recorded_as_artiq_results_import_as_recorded(campaign, tmp_path,
                                                                      capsys):
    folder, schedule = campaign
    lab, imported = tmp_path / "lab", tmp_path / "imported"
    _cli(["write-artiq-results", folder, lab, "--schedule", schedule], capsys)
    files = sorted(p.name for p in lab.glob("results/*/*/*.h5"))
    assert [f.split("-", 1)[1] for f in files] == ["AmplitudeCalibration.h5"] + [
        "PulseResponse.h5"] * 2
    mapping = read_mapping(lab / "mapping.toml")
    assert [s.table for s in mapping.sources] == ["calibration_amplitude", "pulse_response"]
    _cli(["import", lab / "mapping.toml", "-o", imported], capsys)
    cfg = CampaignConfig.from_truth(json.loads((folder / "truth.json").read_text()))
    want = record_further(cfg, schedule_measurements(read_schedule(schedule))).tables[
        "pulse_response"]
    got = pd.read_csv(imported / "pulse_response.csv")
    pd.testing.assert_frame_equal(got[list(want.columns)], want, check_exact=True,
                                  check_dtype=False)
    read = CampaignFolder(imported).pulse_response
    assert read["step"].nunique() == 2
    assert read.groupby("step")["A"].first().tolist() == [A for _, A in _TRACES]


def test_a_campaigns_own_trace_written_whole_and_imported_back(tmp_path, capsys):
    cfg = dataclasses.replace(SMALL, pulse_traces=1)
    own_table_round_trip(cfg, tmp_path, capsys, "pulse_response", "PulseResponse")


def test_the_mapping_written_for_a_campaign_without_it_has_no_pulse_source(tmp_path):
    from dpdfit.simulation.artiq_results import write_ndscan_campaign
    from tests.helpers.bundled_data import CAMPAIGN
    import tomllib
    assert "pulse_response" in tomllib.loads((MAPPINGS / "ndscan_campaign.toml").read_text())
    text = write_ndscan_campaign(CAMPAIGN, tmp_path / "lab").read_text()
    assert "pulse_response" not in tomllib.loads(text) and "PulseResponse" not in text


def _pulse_mapping(tmp_path, old: str, new: str):
    text = (MAPPINGS / "ndscan_campaign.toml").read_text()
    head, pulse = text.split("\n[[pulse_response]]")
    changed = pulse.replace(old, new)
    assert changed != pulse
    path = tmp_path / "mapping.toml"
    path.write_text(head + "\n[[pulse_response]]" + changed)
    return path


@pytest.mark.parametrize("old, new, words", [
    ('t_us = { axis = "delay" }', "t_us = 0.5", "time axis cannot be a constant"),
    ('A = { argument = "amplitude" }', "A = 0.0", "outside (0, 1]"),
    ('power = { channel = "pd_power" }', "power = { value = -0.1 }", "is negative"),
])
def test_a_constant_no_pulse_response_holds_is_one_line(tmp_path, capsys, old, new, words):
    path = _pulse_mapping(tmp_path, old, new)
    with pytest.raises(InputError) as exc:
        read_mapping(path)
    msg = str(exc.value)
    assert len(msg.splitlines()) == 1 and words in msg, msg
    assert "pulse_response[1].columns." in msg
    assert main(["import", str(path), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and words in err, err
    assert not (tmp_path / "out").exists()
