"""``thermometry.csv``: the sideband thermometry table, read and refused like every table."""

import shutil
import subprocess
import sys

import pytest

from dpdfit.errors import ImplausibleValueError, InputError
from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.recordings.columns import CAMPAIGN_TABLES
from dpdfit.recordings.thermometry import read_thermometry
from tests.helpers.paths import ROOT

GOOD = ("wait_us,sideband,n_bright,shots\n0,red,195,200\n0,blue,30,200\n"
        "5000,red,170,200\n5000,blue,40,200\n")


def _write(tmp_path, text):
    p = tmp_path / "thermometry.csv"
    p.write_text(text)
    return p


def test_read_and_pool(tmp_path):
    text = GOOD + "0,Red ,97,100\n"
    df = read_thermometry(_write(tmp_path, text))
    assert df["sideband"].tolist() == ["red", "blue", "red", "blue"]
    assert df["shots"].tolist() == [300, 200, 200, 200]
    assert df["n_bright"].tolist() == [292, 30, 170, 40]
    assert df["n_repeats"].tolist() == [2, 1, 1, 1]
    assert df["wait_s"].tolist() == pytest.approx([0, 0, 5e-3, 5e-3])


@pytest.mark.parametrize("row, column, words", [
    ("-10,red,190,200", "wait_us", "negative"),
    ("1,green,190,200", "sideband", "does not exist"),
    ("1,red,201,200", "n_bright", "exceeds shots"),
    ("1,red,19.5,200", "n_bright", "not an integer"),
    ("5000000,red,190,200", "wait_us", "ns written as us"),
])
def test_bad_row_is_one_line(tmp_path, row, column, words):
    p = _write(tmp_path, GOOD + row + "\n")
    with pytest.raises(InputError) as err:
        read_thermometry(p)
    msg = str(err.value)
    assert "\n" not in msg
    assert str(p) in msg and f"column '{column}'" in msg and "row 5" in msg
    assert words in msg
    if column == "wait_us" and "ns" in words:
        assert isinstance(err.value, ImplausibleValueError)


def test_missing_column_named(tmp_path):
    p = _write(tmp_path, "wait_us,n_bright,shots\n0,190,200\n")
    with pytest.raises(InputError, match="sideband"):
        read_thermometry(p)


def test_registered_and_optional_in_folder(tmp_path):
    assert "thermometry" in CAMPAIGN_TABLES
    camp = tmp_path / "c"
    shutil.copytree(ROOT / "datasets" / "synthetic_campaign", camp)
    assert not (camp / "thermometry.csv").exists()
    cf = CampaignFolder(camp)
    assert cf.thermometry is None
    before = cf.left_out()
    assert not any("thermometry" in line for line in before)
    (camp / "thermometry.csv").write_text(GOOD)
    cf = CampaignFolder(camp)
    assert cf.thermometry["wait_us"].tolist() == [0, 0, 5000, 5000]
    assert cf.left_out() == before
    (camp / "thermometry.csv").write_text(GOOD + "1,red,201,200\n")
    with pytest.raises(InputError, match="thermometry.csv, column 'n_bright', row 5"):
        CampaignFolder(camp).check_plausible()


def test_dpdfit_add_appends_thermometry_rows(tmp_path):
    """``dpdfit add`` takes a NEW folder holding thermometry.csv: into a campaign without
    one (the table appears) and again (the rows are appended, read back pooled)."""
    from dpdfit.recordings.campaign_add import add_recordings
    camp = tmp_path / "c"
    shutil.copytree(ROOT / "datasets" / "synthetic_campaign", camp)
    new = tmp_path / "new"
    new.mkdir()
    (new / "thermometry.csv").write_text(GOOD)
    once = add_recordings(camp, new, added_at="2026-01-02T03:04:05").write(tmp_path / "once")
    assert CampaignFolder(once).thermometry["shots"].tolist() == [200] * 4
    twice = add_recordings(once, new, added_at="2026-01-02T04:04:05").write(tmp_path / "two")
    assert CampaignFolder(twice).thermometry["shots"].tolist() == [400] * 4


@pytest.mark.parametrize("row, column", [("-10,red,190,200", "wait_us"),
                                         ("1,green,190,200", "sideband"),
                                         ("1,red,201,200", "n_bright"),
                                         ("5000000,red,190,200", "wait_us")])
def test_cli_add_refuses_in_one_line_and_writes_nothing(tmp_path, row, column):
    camp = tmp_path / "c"
    shutil.copytree(ROOT / "datasets" / "synthetic_campaign", camp)
    new = tmp_path / "new"
    new.mkdir()
    (new / "thermometry.csv").write_text(GOOD + row + "\n")
    out = tmp_path / "bad"
    r = subprocess.run([sys.executable, "-m", "dpdfit", "add", str(camp), str(new), "-o",
                        str(out)], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and f"column '{column}'" in lines[0] and "row 5" in lines[0]
    assert not out.exists()
