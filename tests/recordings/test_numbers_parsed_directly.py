"""The number columns of a table parsed as numbers directly give the table, and the
refusals, of the strings-first parse.

:func:`dpdfit.recordings.csv_text.parse_csv_table` parses the columns it is told hold
numbers as float64 in one pass (to keep a large table's memory near its file's bytes),
and falls back to :func:`~dpdfit.recordings.csv_text.parse_csv_strings` whenever a cell
or a row is not as a lab writes it.  Whatever the bytes, the two must agree: the same
refusal (type and message), or the same strings and the same numbers as
``pandas.to_numeric`` gives from the strings.
"""

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import example, given
from hypothesis import strategies as st

from dpdfit.errors import InputError
from dpdfit.recordings.csv_text import parse_csv_strings, parse_csv_table

_NUMBER_COLUMNS = ["A", "power"]


def _cells():
    numbers = st.floats(allow_nan=False, allow_infinity=False, width=64).map(repr)
    written = st.sampled_from(["1.", ".5", "+3", "-0", "1E5", " 2.5", "4 ", "-2.5e-3",
                               "1e400", "-1e-400", "nan", "inf", "-inf", "", "NA", "x",
                               "=1+1", "-x", "@a", "1,5", '"7"', "0x10", "1_0"])
    return st.one_of(numbers, numbers, numbers, written)


@st.composite
def _tables(draw):
    header = draw(st.sampled_from(["run,A,power", "A,power,note", "A , power", "A,power,A",
                                   "run,A,power\n# a comment"]))
    width = header.split("\n")[0].count(",") + 1
    rows = []
    for _ in range(draw(st.integers(1, 6))):
        kind = draw(st.sampled_from(["row"] * 8 + ["short", "wide", "comment", "blank"]))
        n = {"row": width, "short": width - 1, "wide": width + 1}.get(kind, 0)
        if kind == "comment":
            rows.append("# note")
        elif kind == "blank":
            rows.append("")
        else:
            rows.append(",".join(draw(_cells()) for _ in range(n)))
    end = draw(st.sampled_from(["\n", "\r\n", ""]))
    return (header + "\n" + "\n".join(rows) + end).encode()


def _outcome(parse):
    try:
        return parse()
    except InputError as exc:
        return exc


@given(raw=_tables())
@example(raw=b"run,A,power\nR1,0.5,1e400\n")
@example(raw=b"run,A,power\nR1,0.5\n")
@example(raw=b"run,A,power\nR1,0.5,1,2\n")
@example(raw=b"A,power,A\n1,2,3\n")
@example(raw=b"run,A,power\nR1,0.5,=1+1\n")
@example(raw=b"\xef\xbb\xbfrun,A,power\nR1,0.25,-3.5e-2\n")
@example(raw=b"run,A,power\n0.0,0.0,-0\n")
def test_numbers_parsed_directly_agree_with_strings_first(raw):
    direct = _outcome(lambda: parse_csv_table(raw, "t.csv", _NUMBER_COLUMNS))
    strings = _outcome(lambda: parse_csv_strings(raw, "t.csv"))
    if isinstance(strings, InputError):
        assert type(direct) is type(strings) and str(direct) == str(strings)
        return
    assert not isinstance(direct, InputError), direct
    assert list(direct.columns) == list(strings.columns)
    assert len(direct) == len(strings)
    for col in strings.columns:
        if direct[col].dtype == np.float64:
            assert col in _NUMBER_COLUMNS
            expected = pd.to_numeric(strings[col]).to_numpy(dtype=float)
            got = direct[col].to_numpy()
            # the same doubles, bit for bit, but for the sign of a zero: pandas itself reads
            # "-0" as +0.0 in a column of integers and as -0.0 beside a decimal, so its
            # sign is no property of the cell (physically a zero either way)
            nonzero = expected != 0
            assert ([math.copysign(1, v) for v in got[nonzero]]
                    == [math.copysign(1, v) for v in expected[nonzero]])
            np.testing.assert_array_equal(got, expected)
        else:
            assert direct[col].tolist() == strings[col].tolist()


def test_an_honest_table_has_its_number_columns_as_floats():
    raw = b"run,timestamp,A,power\nR1,2025-01-01T00:00:00+00:00,0.5,-1.25e-3\nR1,2025-01-01T00:00:00+00:00,0.75,2\n"
    df = parse_csv_table(raw, "t.csv", ["A", "power"])
    assert df["A"].dtype == np.float64 and df["power"].dtype == np.float64
    assert df["power"].tolist() == [-1.25e-3, 2.0]
    assert df["run"].tolist() == ["R1", "R1"]


@pytest.mark.parametrize("raw, row", [(b"A,power\n0.5,1\n0.6,\n", 2),
                                      (b"A,power\n0.5,nan\n", 1)])
def test_a_number_column_with_a_hole_is_left_to_the_string_parse(raw, row):
    """Not refused here (the readers decide what a hole means); returned as strings."""
    df = parse_csv_table(raw, "t.csv", ["A", "power"])
    assert df["power"].dtype != np.float64
    assert df["power"].iloc[row - 1] in ("", "nan")
