"""``detector_linearity.csv``: the photodiode read with and without a calibrated
attenuator, read and refused like every table."""

import shutil
import subprocess
import sys

import numpy as np
import pytest

from dpdfit.errors import ImplausibleValueError, InputError
from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.recordings.columns import CAMPAIGN_TABLES
from dpdfit.recordings.detector_linearity import read_detector_linearity
from tests.helpers.paths import ROOT

GOOD = ("A,power,power_attenuated,attenuation_db,power_err\n"
        "0.5,1.0,0.1002,10,0.001\n"
        "1.0,2.0,0.2010,10,0.002\n")


def _write(tmp_path, text, name="detector_linearity.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_read_keeps_every_pair_and_its_transmission(tmp_path):
    df = read_detector_linearity(_write(tmp_path, GOOD + "0.5,1.01,0.1003,10,0.001\n"))
    assert df["A"].tolist() == [0.5, 1.0, 0.5]
    assert np.allclose(df["transmission"], 0.1)
    # the optional columns are optional
    p = _write(tmp_path, "A,power,power_attenuated,attenuation_db\n0.7,1.5,0.15,10\n")
    assert read_detector_linearity(p)["power"].tolist() == [1.5]


@pytest.mark.parametrize("row, column, words, kind", [
    ("0.7,1.5,0.15,0", "attenuation_db", "must be > 0", InputError),
    ("0.7,1.5,0.15,-10", "attenuation_db", "must be > 0", InputError),
    ("0.7,1.5,0.15,0.1", "attenuation_db", "linear factor", ImplausibleValueError),
    ("0.7,1.5,0.15,100", "attenuation_db", "attenuation factor", ImplausibleValueError),
    ("0.7,1.5,0.015,10", "attenuation_db", "ratio shows 20", ImplausibleValueError),
    ("0.7,-1.5,0.15,10", "power", "negative", InputError),
    ("0.7,1.5,-0.15,10", "power_attenuated", "negative", InputError),
    ("0.7,0,0.0,10", "power", "zero", InputError),
    ("1.7,1.5,0.15,10", "A", "outside [0, 1]", InputError),
])
def test_bad_row_is_one_line(tmp_path, row, column, words, kind):
    p = _write(tmp_path, "A,power,power_attenuated,attenuation_db\n0.5,1.0,0.1,10\n"
               + row + "\n")
    with pytest.raises(kind) as err:
        read_detector_linearity(p)
    msg = str(err.value)
    assert "\n" not in msg
    assert str(p) in msg and f"column '{column}'" in msg and "row 2" in msg
    assert words in msg


def test_drive_outside_the_calibration_range_refused(tmp_path):
    p = _write(tmp_path, GOOD)
    with pytest.raises(InputError, match="column 'A'.*row 2.*calibration runs' range"):
        read_detector_linearity(p, a_range=(0.0, 0.8))
    assert len(read_detector_linearity(p, a_range=(0.0, 1.0))) == 2


def _campaign(tmp_path):
    camp = tmp_path / "c"
    shutil.copytree(ROOT / "datasets" / "synthetic_campaign", camp)
    return camp


def test_registered_and_optional_in_folder(tmp_path):
    assert "detector_linearity" in CAMPAIGN_TABLES
    camp = _campaign(tmp_path)
    cf = CampaignFolder(camp)
    assert cf.detector_linearity is None
    before = cf.left_out()
    assert not any("linearity" in line for line in before)
    (camp / "detector_linearity.csv").write_text(
        "A,power,power_attenuated,attenuation_db\n0.5,1.0,0.1,10\n")
    cf = CampaignFolder(camp)
    assert cf.detector_linearity["power"].tolist() == [1.0]
    assert cf.left_out() == before          # power_err absent is not listed either
    (camp / "detector_linearity.csv").write_text(GOOD + "0.5,1.0,0.1,0,0.001\n")
    with pytest.raises(InputError, match="detector_linearity.csv, column 'attenuation_db', "
                                         "row 3"):
        CampaignFolder(camp).check_plausible()


def test_dpdfit_add_appends_rows(tmp_path):
    from dpdfit.recordings.campaign_add import add_recordings
    camp = _campaign(tmp_path)
    new = tmp_path / "new"
    new.mkdir()
    _write(new, GOOD)
    once = add_recordings(camp, new, added_at="2026-01-02T03:04:05").write(tmp_path / "once")
    assert CampaignFolder(once).detector_linearity["A"].tolist() == [0.5, 1.0]
    twice = add_recordings(once, new, added_at="2026-01-02T04:04:05").write(tmp_path / "two")
    assert CampaignFolder(twice).detector_linearity["A"].tolist() == [0.5, 1.0, 0.5, 1.0]


@pytest.mark.parametrize("row, column", [("0.7,1.5,0.15,0,0.001", "attenuation_db"),
                                         ("0.7,1.5,0.15,0.1,0.001", "attenuation_db"),
                                         ("0.7,-1.5,0.15,10,0.001", "power")])
def test_cli_add_refuses_in_one_line_and_writes_nothing(tmp_path, row, column):
    camp = _campaign(tmp_path)
    new = tmp_path / "new"
    new.mkdir()
    _write(new, GOOD + row + "\n")
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "-m", "dpdfit", "add", str(camp), str(new), "-o",
                        str(out)], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 2
    lines = [x for x in r.stderr.splitlines() if x.strip()]
    assert len(lines) == 1, r.stderr
    assert "detector_linearity.csv" in lines[0] and f"column '{column}'" in lines[0]
    assert "row 3" in lines[0]
    assert not out.exists()
