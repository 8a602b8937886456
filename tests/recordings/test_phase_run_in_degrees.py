"""A phase calibration run in degrees among runs in radians is refused even where its span
does not show it (an AOM with a small AM-to-PM): one line naming file, column and row,
from the reader and from ``dpdfit add`` (exit 2, nothing written)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from dpdfit.errors import ImplausibleValueError
from dpdfit.recordings.plausibility import DEGREES_SPAN_RAD
from dpdfit.recordings.tables import read_calibration_table
from dpdfit.simulation.campaign import campaign_hashes, simulate_campaign
from tests.helpers.cli_refusal import assert_refused
from tests.helpers.further_campaign import SEED, small_config

#: the AOM's phase at full drive (rad): in degrees, 2.9, within the span check's 4 pi
PHI_1 = 0.05


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    cfg = dataclasses.replace(small_config(), phi1_mean=PHI_1, n_phase_runs=3)
    out = tmp_path_factory.mktemp("degrees") / "campaign"
    simulate_campaign(out, seed=SEED, config=cfg, progress=False)
    return out


def _degree_run(campaign) -> pd.DataFrame:
    """The campaign's last phase run again an hour later as run P010, in degrees, recorded
    where the phase is measured (``A >= 0.1``: the weak beat's noise below it would
    span degrees whatever the AM-to-PM)."""
    ph = pd.read_csv(campaign / "calibration_phase.csv", dtype={"timestamp": str})
    run = ph[(ph["run"] == ph["run"].iloc[-1]) & (ph["A"] >= 0.1)].copy()
    run["run"] = "P010"
    t = pd.to_datetime(run["timestamp"], utc=True) + pd.Timedelta(hours=1)
    run["timestamp"] = t.dt.strftime("%Y-%m-%dT%H:%M:%S+00:00")
    run["phase_rad"] = np.degrees(run["phase_rad"])
    run["phase_err"] = np.degrees(run["phase_err"])
    return run


def test_the_reader_refuses_it(campaign, tmp_path):
    run = _degree_run(campaign)
    ph = pd.read_csv(campaign / "calibration_phase.csv", dtype={"timestamp": str})
    path = tmp_path / "calibration_phase.csv"
    both = pd.concat([ph, run], ignore_index=True)
    both.to_csv(path, index=False)
    # its span alone looks like radians
    assert np.ptp(run["phase_rad"]) < DEGREES_SPAN_RAD
    with pytest.raises(ImplausibleValueError) as exc:
        read_calibration_table(path, "phase")
    msg = str(exc.value)
    assert len(msg.splitlines()) == 1
    row = int(np.argmax(np.abs(run["phase_rad"].to_numpy()))) + len(ph) + 1
    assert msg.startswith(f"{path}, column 'phase_rad', row {row}: the phases of run P010 are ")
    assert "in degrees?" in msg
    # the campaign's own runs in radians pass
    read_calibration_table(campaign / "calibration_phase.csv", "phase")


def test_dpdfit_add_refuses_it(campaign, tmp_path, capsys):
    new = tmp_path / "new"
    new.mkdir()
    _degree_run(campaign).to_csv(new / "calibration_phase.csv", index=False)
    before = campaign_hashes(campaign)
    out = tmp_path / "out"
    line = assert_refused(capsys, ["add", campaign, new, "-o", out],
                          ["calibration_phase.csv", "column 'phase_rad'", "run P010",
                           "those of the other runs", "in degrees?"], inputs=[new / "calibration_phase.csv"])
    assert "row " in line
    assert campaign_hashes(campaign) == before
    assert not out.exists() or not any(out.iterdir())
