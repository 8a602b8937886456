"""``spam.csv``: the SPAM characterisation table, read and refused like every table."""

import shutil

import pytest

from dpdfit.errors import InputError
from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.recordings.columns import CAMPAIGN_TABLES
from dpdfit.recordings.spam import read_spam
from tests.helpers.paths import ROOT

GOOD = "prepared,n00,n01_10,n11,shots\n00,995,5,0,1000\n11,4,6,990,1000\n"


def _write(tmp_path, text):
    p = tmp_path / "spam.csv"
    p.write_text(text)
    return p


def test_read_and_pool(tmp_path):
    text = GOOD + "00,497,3,0,500\n|11>,1,2,497,500\n"
    df = read_spam(_write(tmp_path, text))
    assert df["prepared"].tolist() == ["00", "11"]
    assert df["shots"].tolist() == [1500, 1500]
    assert df["n00"].tolist() == [1492, 5]
    assert df["n_repeats"].tolist() == [2, 2]


@pytest.mark.parametrize("row, column, words", [
    ("02,990,5,5,1000", "prepared", "does not exist"),
    ("0,990,5,5,1000", "prepared", "leading zero"),
    ("11,4,6,1001,1000", "n11", "exceeds shots"),
    ("11,-4,6,998,1000", "n00", "negative"),
    ("11,4,6,980,1000", "shots", "differs from shots"),
    ("11,4.5,6,989.5,1000", "n00", "not an integer"),
])
def test_bad_row_is_one_line(tmp_path, row, column, words):
    p = _write(tmp_path, GOOD + row + "\n")
    with pytest.raises(InputError) as err:
        read_spam(p)
    msg = str(err.value)
    assert "\n" not in msg
    assert str(p) in msg and f"column '{column}'" in msg and "row 3" in msg
    assert words in msg


def test_missing_column_named(tmp_path):
    p = _write(tmp_path, "prepared,n00,n11,shots\n00,1000,0,1000\n")
    with pytest.raises(InputError, match="n01_10"):
        read_spam(p)


def test_registered_and_optional_in_folder(tmp_path):
    assert "spam" in CAMPAIGN_TABLES
    camp = tmp_path / "c"
    shutil.copytree(ROOT / "datasets" / "synthetic_campaign", camp)
    for f in ("spam.csv",):
        assert not (camp / f).exists()
    cf = CampaignFolder(camp)
    assert cf.spam is None
    before = cf.left_out()
    assert not any("spam" in line for line in before)
    (camp / "spam.csv").write_text(GOOD)
    cf = CampaignFolder(camp)
    assert cf.spam["prepared"].tolist() == ["00", "11"]
    assert cf.left_out() == before
    (camp / "spam.csv").write_text(GOOD + "11,4,6,1001,1000\n")
    with pytest.raises(InputError, match="spam.csv, column 'n11', row 3"):
        CampaignFolder(camp).check_plausible()


def test_dpdfit_add_appends_spam_rows(tmp_path):
    """``dpdfit add`` takes a NEW folder holding spam.csv: into a campaign without one
    (the table appears) and again (the rows are appended, read back pooled)."""
    from dpdfit.recordings.campaign_add import add_recordings
    camp = tmp_path / "c"
    shutil.copytree(ROOT / "datasets" / "synthetic_campaign", camp)
    new = tmp_path / "new"
    new.mkdir()
    (new / "spam.csv").write_text(GOOD)
    once = add_recordings(camp, new, added_at="2026-01-02T03:04:05").write(tmp_path / "once")
    assert CampaignFolder(once).spam["shots"].tolist() == [1000, 1000]
    twice = add_recordings(once, new, added_at="2026-01-02T04:04:05").write(tmp_path / "two")
    assert CampaignFolder(twice).spam["shots"].tolist() == [2000, 2000]
    (new / "spam.csv").write_text(GOOD + "11,4,6,1001,1000\n")
    with pytest.raises(InputError, match="spam.csv.*column 'n11'.*row 3"):
        add_recordings(camp, new).write(tmp_path / "bad")
    assert not (tmp_path / "bad").exists()
