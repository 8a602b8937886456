"""A schedule's rows are counted as it is read: one with more than
:data:`~dpdfit.core.defaults.MAX_SCHEDULE_ROWS` is refused as soon as its reading passes
them, the rest unread (a 10^7-row schedule was parsed whole first: 23 s, 2 GB).

The count is the parser's (comment and blank lines skipped, the header not a row), in
chunks of any size; a schedule of the bound itself is read whole.
"""

from __future__ import annotations

import functools
import tracemalloc

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from dpdfit.core.defaults import MAX_SCHEDULE_ROWS
from dpdfit.errors import InputError
from dpdfit.recordings import tables
from dpdfit.recordings.input_files import read_input_chunks
from dpdfit.recordings.schedule import read_schedule
from dpdfit.recordings.tables import read_csv_strings

HEADER = "kind,repeat,point,A,dpd,shots,phase_rad,t_us,lab_s\n"


def _schedule_rows(n: int) -> str:
    """``n`` rows of one amplitude run (points 0..n-1)."""
    return "".join(f"amplitude_run,1,{i},0.5,,,,,1.0\n" for i in range(n))


_LINE = st.one_of(st.just(("row", "1,2")), st.just(("row", " 3 , 4 ")),
                  st.just(("skip", "# a comment, with, commas")), st.just(("skip", "")),
                  st.just(("skip", "  \t ")), st.just(("skip", "#")))


@settings(max_examples=300, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(lines=st.lists(_LINE, max_size=40), chunk=st.integers(1, 17),
       crlf=st.booleans(), bom=st.booleans(), lead=st.lists(_LINE.filter(
           lambda x: x[0] == "skip"), max_size=3))
def test_rows_are_counted_as_the_parser_counts_them(tmp_path_factory, monkeypatch, lines,
                                                    chunk, crlf, bom, lead):
    """Any mix of rows, comments and blank lines, in chunks of 1 to 17 bytes: the file is
    read with a bound of its own row count, and refused with one row less."""
    monkeypatch.setattr(tables, "read_input_chunks",
                        functools.partial(read_input_chunks, size=chunk))
    end = "\r\n" if crlf else "\n"
    text = "".join(t + end for _, t in lead) + "a,b" + end + "".join(t + end for _, t in lines)
    path = tmp_path_factory.mktemp("rows") / "t.csv"
    path.write_bytes((b"\xef\xbb\xbf" if bom else b"") + text.encode())
    rows = sum(kind == "row" for kind, _ in lines)
    assert len(read_csv_strings(path)) == rows
    assert len(read_csv_strings(path, max_rows=rows)) == rows
    if rows:
        with pytest.raises(InputError, match=f"more than {rows - 1} rows"):
            read_csv_strings(path, max_rows=rows - 1)


def test_a_schedule_of_the_bound_is_read_whole(tmp_path):
    path = tmp_path / "schedule.csv"
    path.write_text(HEADER + "# the largest schedule there is\n"
                    + _schedule_rows(MAX_SCHEDULE_ROWS))
    assert len(read_schedule(path)) == MAX_SCHEDULE_ROWS


def test_a_schedule_beyond_the_bound_is_refused_before_the_rest_is_read(tmp_path):
    """One row more than the bound, then a sparse gigabyte of zeros: refused on its rows
    (read whole, it would be refused for its NUL bytes after reading the gigabyte), in
    the memory of the rows read."""
    path = tmp_path / "schedule.csv"
    path.write_text(HEADER + _schedule_rows(MAX_SCHEDULE_ROWS + 1))
    read = path.stat().st_size
    with open(path, "r+b") as fh:
        fh.truncate(2**30 - 1)
    before = path.stat()
    tracemalloc.start()
    try:
        with pytest.raises(InputError) as err:
            read_schedule(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    msg = str(err.value)
    assert msg == (f"{path}: has more than {MAX_SCHEDULE_ROWS} rows, the most dpdfit reads "
                   "from this file (the rest of it was not read)")
    assert peak < 4 * read                       # the rows read, not the gigabyte
    assert path.stat().st_size == before.st_size and path.stat().st_mtime == before.st_mtime
