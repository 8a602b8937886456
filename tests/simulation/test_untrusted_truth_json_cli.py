"""``dpdfit write-artiq-results CAMPAIGN OUT --schedule S.csv`` on a campaign whose truth.json
config was edited: one line naming truth.json and the key, exit 2, nothing simulated,
nothing written, the inputs unchanged."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pandas as pd
import pytest

import dpdfit.simulation.recorded_artiq as recorded_artiq
from dpdfit.recordings.schedule import write_schedule
from dpdfit.simulation.campaign import simulate_campaign
from tests.helpers.standin import SMALL
from dpdfit.simulation.truth_edits import edited
from tests.helpers.untrusted_campaign import (assert_refused_in_process,
                                              assert_refused_in_subprocess)

pytest.importorskip("h5py")


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    """A small simulated campaign (calibrations and spectra) and a schedule for it."""
    root = tmp_path_factory.mktemp("truth_cli")
    folder = root / "campaign"
    simulate_campaign(folder, config=SMALL, progress=False, include_gates=False)
    grid = np.round(np.linspace(0.0, 1.0, SMALL.cal_points), 10)
    rows = [{"kind": "amplitude_run", "repeat": 1, "point": i, "A": a, "lab_s": 1.0}
            for i, a in enumerate(grid)]
    schedule = root / "schedule.csv"
    write_schedule(pd.DataFrame(rows), schedule)
    return folder, schedule


@pytest.fixture
def lab(simulated, tmp_path):
    """A copy of the campaign and its schedule in this test's folder, and the truth.json
    as the simulator wrote it."""
    folder, schedule = simulated
    shutil.copytree(folder, tmp_path / "campaign")
    shutil.copy(schedule, tmp_path / "schedule.csv")
    truth = json.loads((tmp_path / "campaign" / "truth.json").read_text())
    return tmp_path, truth


def _with_config(root, truth: dict, path: tuple, value) -> None:
    config = edited(truth["config"], path, value)
    (root / "campaign" / "truth.json").write_text(json.dumps({**truth, "config": config},
                                                             indent=2))


ARGV = ["write-artiq-results", "campaign", "out", "--schedule", "schedule.csv"]


@pytest.mark.parametrize(("path", "value", "line"), [
    (("n_samples",), -1, "campaign/truth.json: config key 'n_samples' must be an integer in "
                         "[1, 2^24], not -1"),
    (("scan_shots", 0, 1), "625", "campaign/truth.json: config key 'scan_shots[0][1]' must "
                                  "be an integer in [1, 1000000000], not '625'"),
    (("cal_points",), 10 ** 40, "campaign/truth.json: config key 'cal_points' must be an "
                                "integer in [2, 10001], not an integer of more than 30 digits"),
    (("A_corr_tau_days",), float("nan"), "campaign/truth.json: config key 'A_corr_tau_days' "
                                         "must be a number in [1e-05, 400000], not NaN"),
    (("injected", 0, 1, 0, 0), "p_\x1b[2J", "campaign/truth.json: config key "
                                            "'injected[0][1][0][0]' must be a parameter of "
                                            "spam_offset"),
])
def test_an_edited_truth_is_refused_in_one_line(lab, path, value, line):
    root, truth = lab
    _with_config(root, truth, path, value)
    got, _ = assert_refused_in_subprocess(ARGV, root, root / "out", needles=[line])
    assert got.startswith(f"dpdfit: error: {line}"), got


def test_a_truth_refused_before_anything_is_simulated(lab, capsys, monkeypatch):
    root, truth = lab

    def simulated(*args, **kwargs):
        raise AssertionError("the simulator ran on a refused truth.json")

    monkeypatch.setattr(recorded_artiq, "record_further", simulated)
    monkeypatch.chdir(root)
    for path, value, key in ((("photodiode",), [1, 2], "photodiode"),
                             (("further", 0), ["scan", 0.4, 1, -5, 0], "further[0][3]"),
                             (("fs",), 1e308, "fs"),
                             (("start",), "2025-13-01", "start")):
        _with_config(root, truth, path, value)
        assert_refused_in_process(capsys, ARGV, root / "campaign", root / "out",
                                  needles=["campaign/truth.json: config key", f"'{key}'"])


def test_the_unedited_truth_still_records_the_schedule(lab, capsys, monkeypatch):
    root, truth = lab
    monkeypatch.chdir(root)
    from dpdfit.cli.main import main
    assert main(ARGV) == 0, capsys.readouterr().err
    assert "51 calibration_amplitude" in capsys.readouterr().out
