"""``ramsey.csv``: the Ramsey and spin-echo table, read and refused like every table."""

import shutil

import pytest

from dpdfit.errors import ImplausibleValueError, InputError
from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.recordings.columns import CAMPAIGN_TABLES
from dpdfit.recordings.ramsey import read_ramsey
from tests.helpers.cli_refusal import assert_refused
from tests.helpers.paths import ROOT

GOOD = ("sequence,wait_us,n00,n01_10,n11,shots\n"
        "ramsey,0,1,8,191,200\nramsey,20000,30,80,90,200\n"
        "echo,0,0,9,191,200\necho,20000,20,70,110,200\n")


def _write(tmp_path, text):
    p = tmp_path / "ramsey.csv"
    p.write_text(text)
    return p


def test_read_and_pool(tmp_path):
    text = GOOD + "Ramsey ,20000,16,40,44,100\n"
    df = read_ramsey(_write(tmp_path, text))
    assert df["sequence"].tolist() == ["ramsey", "ramsey", "echo", "echo"]
    assert df["shots"].tolist() == [200, 300, 200, 200]
    assert df["n00"].tolist() == [1, 46, 0, 20]
    assert df["n_repeats"].tolist() == [1, 2, 1, 1]
    assert df["wait_s"].tolist() == [0.0, 0.02, 0.0, 0.02]


@pytest.mark.parametrize("row, column, words", [
    ("hahn,100,10,10,180,200", "sequence", "does not exist"),
    ("ramsey,-5,10,10,180,200", "wait_us", "below zero"),
    ("echo,100,10,10,201,200", "n11", "exceeds shots"),
    ("echo,100,10,-10,200,200", "n01_10", "negative"),
    ("echo,100,10,10,170,200", "shots", "differs from shots"),
])
def test_bad_row_is_one_line(tmp_path, row, column, words):
    p = _write(tmp_path, GOOD + row + "\n")
    with pytest.raises(InputError) as err:
        read_ramsey(p)
    msg = str(err.value)
    assert "\n" not in msg
    assert str(p) in msg and f"column '{column}'" in msg and "row 5" in msg
    assert words in msg


def test_missing_column_named(tmp_path):
    p = _write(tmp_path, "sequence,n00,n01_10,n11,shots\nramsey,1,8,191,200\n")
    with pytest.raises(InputError, match="wait_us"):
        read_ramsey(p)


def _campaign(tmp_path):
    camp = tmp_path / "c"
    shutil.copytree(ROOT / "datasets" / "synthetic_campaign", camp)
    return camp


def test_registered_and_optional_in_folder(tmp_path):
    assert "ramsey" in CAMPAIGN_TABLES
    camp = _campaign(tmp_path)
    assert not (camp / "ramsey.csv").exists()
    cf = CampaignFolder(camp)
    assert cf.ramsey is None
    before = cf.left_out()
    assert not any("ramsey" in line for line in before)
    (camp / "ramsey.csv").write_text(GOOD)
    cf = CampaignFolder(camp)
    assert cf.ramsey["sequence"].tolist() == ["ramsey", "ramsey", "echo", "echo"]
    assert cf.left_out() == before
    (camp / "ramsey.csv").write_text(GOOD + "echo,100,10,10,201,200\n")
    with pytest.raises(InputError, match="ramsey.csv, column 'n11', row 5"):
        CampaignFolder(camp).check_plausible()


@pytest.mark.parametrize("scale, words", [(1e3, "stored in ns"), (1e-6, "stored in s or ms"),
                                          (1e-3, "stored in s or ms")])
def test_waits_in_another_unit_refused(tmp_path, scale, words):
    """Waits of a 50 ms coherence time written in ns, s or ms under ``wait_us``: refused
    against campaign.json's T2, naming the row."""
    camp = _campaign(tmp_path)
    waits = [0, 500, 5000, 20000, 60000]
    rows = "".join(f"{s},{w * scale:g},50,50,100,200\n" for s in ("ramsey", "echo")
                   for w in waits)
    (camp / "ramsey.csv").write_text("sequence,wait_us,n00,n01_10,n11,shots\n" + rows)
    with pytest.raises(ImplausibleValueError) as err:
        CampaignFolder(camp).check_plausible()
    msg = str(err.value)
    assert "\n" not in msg and "column 'wait_us'" in msg and words in msg and "T2" in msg


def test_dpdfit_add_appends_ramsey_rows(tmp_path):
    """``dpdfit add`` takes a NEW folder holding ramsey.csv: into a campaign without one
    (the table appears) and again (the rows are appended, read back pooled)."""
    from dpdfit.recordings.campaign_add import add_recordings
    camp = _campaign(tmp_path)
    new = tmp_path / "new"
    new.mkdir()
    (new / "ramsey.csv").write_text(GOOD)
    once = add_recordings(camp, new, added_at="2026-01-02T03:04:05").write(tmp_path / "once")
    assert CampaignFolder(once).ramsey["shots"].tolist() == [200] * 4
    twice = add_recordings(once, new, added_at="2026-01-02T04:04:05").write(tmp_path / "two")
    assert CampaignFolder(twice).ramsey["shots"].tolist() == [400] * 4


@pytest.mark.parametrize("row, needles", [
    ("ramsey,-5,10,10,180,200", ["ramsey.csv", "column 'wait_us'", "row 5", "below zero"]),
    ("echo,100,10,10,201,200", ["ramsey.csv", "column 'n11'", "row 5", "exceeds shots"]),
    ("cpmg,100,10,10,180,200", ["ramsey.csv", "column 'sequence'", "row 5", "does not exist"]),
    ("echo,5e10,10,10,180,200", ["ramsey.csv", "column 'wait_us'", "row 5", "stored in ns"]),
])
def test_dpdfit_add_refuses_bad_rows(tmp_path, capsys, row, needles):
    """From the command line: one line, exit 2, nothing written."""
    camp = _campaign(tmp_path)
    new = tmp_path / "new"
    new.mkdir()
    (new / "ramsey.csv").write_text(GOOD + row + "\n")
    out = tmp_path / "out"
    assert_refused(capsys, ["add", camp, new, "-o", out], needles,
                   inputs=[new / "ramsey.csv", camp / "campaign.json"])
    assert not out.exists()
