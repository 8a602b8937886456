"""``pulse_response.csv``: the AOM pulse response table, read and refused like every table."""

import shutil

import pytest

from dpdfit.errors import ImplausibleValueError, InputError
from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.recordings.columns import CAMPAIGN_TABLES
from dpdfit.recordings.pulse_response import read_pulse_response
from tests.helpers.cli_refusal import assert_refused
from tests.helpers.paths import ROOT

GOOD = ("t_us,power,A,power_err\n0.01,0.20,0.5,0.002\n0.02,0.50,0.5,0.002\n"
        "0.05,0.60,0.5,0.002\n1.0,0.62,0.5,0.002\n")


def _write(tmp_path, text):
    p = tmp_path / "pulse_response.csv"
    p.write_text(text)
    return p


def test_read_steps(tmp_path):
    """Steps: a change of A, and a trace recorded again (its time starting over)."""
    text = GOOD + "0.01,0.30,0.7,0.002\n0.5,0.8,0.7,0.002\n0.01,0.31,0.7,0.002\n"
    df = read_pulse_response(_write(tmp_path, text))
    assert df["step"].tolist() == [0, 0, 0, 0, 1, 1, 2]
    assert df["A"].tolist() == [0.5] * 4 + [0.7] * 3


def test_default_amplitude(tmp_path):
    p = _write(tmp_path, "t_us,power\n0.01,0.2\n0.1,0.5\n")
    assert read_pulse_response(p, default_A=0.6)["A"].tolist() == [0.6, 0.6]
    with pytest.raises(InputError, match="column 'A'.*no drive amplitude"):
        read_pulse_response(p)


@pytest.mark.parametrize("row, column, words, kind", [
    ("0.04,0.61,0.5,0.002", "t_us", "does not increase within its step", InputError),
    ("0.05,0.61,0.5,0.002", "t_us", "does not increase within its step", InputError),
    ("2000,0.61,0.5,0.002", "t_us", "written in ns", ImplausibleValueError),
    ("2.0,-0.01,0.5,0.002", "power", "negative reading", InputError),
    ("2.0,0.61,50,0.002", "A", "outside [0, 1]", ImplausibleValueError),
    ("2.0,0.61,0.5,0", "power_err", "must be > 0", InputError),
])
def test_bad_row_is_one_line(tmp_path, row, column, words, kind):
    lines = GOOD.splitlines()
    lines.insert(4, row)                 # after the third sample (t = 0.05), data row 4
    p = _write(tmp_path, "\n".join(lines) + "\n")
    with pytest.raises(kind) as err:
        read_pulse_response(p)
    msg = str(err.value)
    assert "\n" not in msg
    assert str(p) in msg and f"column '{column}'" in msg and "row 4" in msg
    assert words in msg


def test_no_time_axis_is_named(tmp_path):
    p = _write(tmp_path, "time,power\n0.01,0.2\n")
    with pytest.raises(InputError) as err:
        read_pulse_response(p)
    assert str(err.value).endswith("pulse_response.csv has no time axis (column t_us)")


def test_registered_and_optional_in_folder(tmp_path):
    assert "pulse_response" in CAMPAIGN_TABLES
    camp = tmp_path / "c"
    shutil.copytree(ROOT / "datasets" / "synthetic_campaign", camp)
    cf = CampaignFolder(camp)
    assert cf.pulse_response is None
    before = cf.left_out()
    assert not any("pulse" in line for line in before)
    (camp / "pulse_response.csv").write_text("t_us,power\n0.01,0.2\n0.1,0.5\n")
    cf = CampaignFolder(camp)
    # no A: the time scans' amplitude (the gate's)
    assert cf.pulse_response["A"].tolist() == [float(cf.time_scans["A"].iloc[0])] * 2
    assert cf.left_out() == before
    (camp / "pulse_response.csv").write_text("t_us,power\n0.01,0.2\n0.1,-0.5\n")
    with pytest.raises(InputError, match="pulse_response.csv, column 'power', row 2"):
        CampaignFolder(camp).check_plausible()


def test_dpdfit_add_appends_pulse_rows(tmp_path, capsys):
    """``dpdfit add`` takes a NEW folder holding pulse_response.csv: into a campaign
    without one and again (a further step); a bad table is refused in one line, exit 2,
    nothing written."""
    from dpdfit.recordings.campaign_add import add_recordings
    camp = tmp_path / "c"
    shutil.copytree(ROOT / "datasets" / "synthetic_campaign", camp)
    new = tmp_path / "new"
    new.mkdir()
    (new / "pulse_response.csv").write_text(GOOD)
    once = add_recordings(camp, new, added_at="2026-01-02T03:04:05").write(tmp_path / "once")
    assert CampaignFolder(once).pulse_response["step"].tolist() == [0] * 4
    twice = add_recordings(once, new, added_at="2026-01-02T04:04:05").write(tmp_path / "two")
    assert CampaignFolder(twice).pulse_response["step"].tolist() == [0] * 4 + [1] * 4
    for text, needles in (("time,power\n0.01,0.2\n", ["no time axis (column t_us)"]),
                          (GOOD + "0.5,0.3,0.5,0.002\n",
                           ["column 't_us'", "row 5", "does not increase"]),
                          (GOOD + "2.0,-0.3,0.5,0.002\n",
                           ["column 'power'", "row 5", "negative reading"]),
                          (GOOD + "5000,0.3,0.5,0.002\n",
                           ["column 't_us'", "row 5", "written in ns"])):
        (new / "pulse_response.csv").write_text(text)
        out = tmp_path / "bad"
        assert_refused(capsys, ["add", camp, new, "-o", out],
                       ["pulse_response.csv", *needles], inputs=[new / "pulse_response.csv"])
        assert not out.exists()
