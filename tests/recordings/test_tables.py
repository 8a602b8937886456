import numpy as np
import pytest

from dpdfit.errors import InputError
from dpdfit.recordings.tables import read_calibration, read_table


def good_rows(n=12):
    A = np.linspace(0, 1, n)
    return "\n".join(f"{a:.3f},{np.sin(a):.6f}" for a in A)


def test_reads_comments_and_extra_columns(write_csv):
    p = write_csv("# a comment\nA,power,extra\n0.1,0.2,x\n0.2,0.3,y\n")
    df = read_table(p, ["A", "power"])
    assert list(df["A"]) == [0.1, 0.2]


@pytest.mark.parametrize("text, needle", [
    ("A,pwr\n0.1,1\n", "column 'power': required column is missing (found 'pwr': misspelt?)"),
    ("A,foo\n0.1,1\n", "column 'power': required column is missing; columns present"),
    ("A,power\n0.1,1\n0.2,nan\n", "column 'power', row 2: value is NaN"),
    ("A,power\n0.1,1\n0.2,\n", "column 'power', row 2: value is empty"),
    ("A,power\n0.1,1\n0.2,inf\n", "column 'power', row 2: value is inf"),
    ("A,power\n0.1,1\n0.2,abc\n", "column 'power', row 2: 'abc' is not a number"),
    ("A,power\n0.1,1\n1.2,3\n", "column 'A', row 2: value 1.2 is outside [0, 1]"),
    ("A,power\n-0.1,1\n", "column 'A', row 1: value -0.1 is outside [0, 1]"),
    ("A,power\n", "no data rows"),
    ("", "file is empty"),
    ("A,power,power_err\n0.1,1,0\n", "column 'power_err', row 1: uncertainty 0 must be > 0"),
])
def test_bad_input_one_line(write_csv, text, needle):
    p = write_csv(text)
    with pytest.raises(InputError) as exc:
        read_calibration(p, "amplitude")
    msg = str(exc.value)
    assert needle in msg
    assert str(p) in msg
    assert "\n" not in msg


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match="file not found"):
        read_calibration(tmp_path / "nope.csv", "amplitude")


def test_bad_timestamp(write_csv):
    p = write_csv("run,timestamp,A,power\nr1,2026-01-01T00:00,0.1,1\nr1,yesterday,0.2,2\n")
    with pytest.raises(InputError, match=r"column 'timestamp', row 2: 'yesterday' is not a date"):
        read_calibration(p, "amplitude")


def test_run_selection(write_csv):
    p = write_csv("run,timestamp,A,power\n"
                  "a,2026-01-02T00:00,0.1,1\na,2026-01-02T00:00,0.2,2\n"
                  "b,2026-01-01T00:00,0.1,3\nb,2026-01-01T00:00,0.2,4\n")
    with pytest.raises(InputError, match="holds 2 runs"):
        read_calibration(p, "amplitude")
    d = read_calibration(p, "amplitude", "b")
    assert d.run == "b" and list(d.value) == [3, 4] and list(d.rows) == [3, 4]
    latest = read_calibration(p, "amplitude", "latest")
    assert latest.run == "a"
    with pytest.raises(InputError, match="run 'c' not found"):
        read_calibration(p, "amplitude", "c")


def test_single_run_label_needs_no_selection(write_csv):
    p = write_csv("run,A,power\nx,0.1,1\nx,0.2,2\n")
    assert read_calibration(p, "amplitude").run == "x"
