"""The one reader of files from elsewhere (:mod:`dpdfit.recordings.input_files`): what it
sets aside to read a file, and JSON nested deeper than the code walking it can follow."""

from __future__ import annotations

import json
import os
import tracemalloc

import pytest
from hypothesis import given
from hypothesis import strategies as st

from dpdfit.core.defaults import MAX_JSON_DEPTH
from dpdfit.errors import InputError
from dpdfit.recordings.input_files import json_depth, read_input_bytes, read_input_json


def test_a_small_file_is_read_in_the_memory_of_its_bytes(tmp_path):
    """A read of the bound (1 GiB) would set it aside whole for a file of ten bytes."""
    p = tmp_path / "small.csv"
    p.write_bytes(b"A,power\n1,2\n")
    tracemalloc.start()
    try:
        data = read_input_bytes(p)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert data == b"A,power\n1,2\n"
    assert peak < 2**20, peak


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="no /proc")
def test_a_file_holding_more_than_its_size_says_is_read_whole():
    """A regular file of size 0 that holds text (``/proc``): read on past its size."""
    data = read_input_bytes("/proc/self/status")
    assert b"Name:" in data and data.endswith(b"\n")


def test_a_file_beyond_a_given_bound_is_refused(tmp_path):
    p = tmp_path / "large.json"
    p.write_bytes(b"[1, 2, 3]")
    with pytest.raises(InputError, match="large.json: is 9 bytes, more than the 8 bytes"):
        read_input_bytes(p, limit=8)


_JSON = st.recursive(st.one_of(st.none(), st.booleans(), st.integers(), st.text(max_size=3)),
                     lambda inner: st.one_of(st.lists(inner, max_size=3),
                                             st.dictionaries(st.text(max_size=2), inner,
                                                             max_size=3)),
                     max_leaves=30)


def _depth(v) -> int:
    if isinstance(v, dict):
        return 1 + max(map(_depth, v.values()), default=0)
    if isinstance(v, list):
        return 1 + max(map(_depth, v), default=0)
    return 0


@given(value=_JSON, stop=st.integers(0, 6))
def test_json_depth_counts_the_levels_of_lists_and_objects(value, stop):
    depth = _depth(value)
    assert json_depth(value) == depth
    if depth <= stop:
        assert json_depth(value, stop) == depth
    else:
        assert json_depth(value, stop) > stop


@pytest.mark.parametrize("depth", [MAX_JSON_DEPTH + 1, 200, 500])
def test_json_deeper_than_the_bound_is_refused_naming_the_file(tmp_path, depth):
    """Parsed, JSON of 500 levels would stop the code walking it (to_jsonable: two calls
    a level) with a RecursionError, which named no file."""
    p = tmp_path / "deep.json"
    p.write_text('{"a": ' + "[" * (depth - 1) + "]" * (depth - 1) + "}")
    with pytest.raises(InputError) as err:
        read_input_json(p, what="diagnosis JSON file")
    assert str(err.value) == (f"{p}: is nested too deeply: lists and objects more than "
                              f"{MAX_JSON_DEPTH} levels deep, the most dpdfit reads from a "
                              "diagnosis JSON file")


def test_json_at_the_bound_is_read(tmp_path):
    p = tmp_path / "deep.json"
    value = json.loads("[" * MAX_JSON_DEPTH + "]" * MAX_JSON_DEPTH)
    p.write_text(json.dumps(value))
    assert read_input_json(p) == value


def test_json_deeper_than_the_parser_reads_is_refused_naming_the_file(tmp_path):
    p = tmp_path / "deeper.json"
    p.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(InputError, match="deeper.json: is nested too deeply to be read as JSON"):
        read_input_json(p)
