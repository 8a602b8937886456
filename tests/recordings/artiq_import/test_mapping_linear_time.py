"""Reading a mapping and matching name patterns take time linear in their input.

The work is counted, not timed: the Python lines executed (``sys.settrace``) for an
input and for one four times as large, which a linear algorithm keeps near 4x and a
quadratic one takes to 16x.  A backtracking regular expression does its work in C,
out of the count's sight, so the inputs on which it explodes are also run in a
subprocess whose hard timeout is only a guard (they take milliseconds; a
backtracking match took minutes).
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

from dpdfit.recordings.mapping import read_mapping
from dpdfit.recordings.name_patterns import match_name, matching_keys
from tests.helpers.mapping_text import CALIBRATION_STUB
from tests.helpers.paths import ROOT

#: a linear count grows 4x for a 4x input; a quadratic one 16x
LINEAR_RATIO = 6.0
PARITY_BLOCK = '''
[[parity]]
files = "results/p{i}/*.h5"
[parity.columns]
A = {{ argument = "amplitude" }}
dpd = {{ argument = "dpd" }}
phase_rad = {{ axis = "phase", unit = "turn" }}
n_even = {{ channel = "bright_ions", count = [0, 2] }}
shots = {{ channel = "bright_ions", count = "all" }}
'''


def _lines_executed(fn, *args) -> int:
    """The Python lines ``fn(*args)`` executes, in every function it calls."""
    count = 0

    def tracer(frame, event, arg):
        nonlocal count
        count += event == "line"
        return tracer

    before = sys.gettrace()
    sys.settrace(tracer)
    try:
        fn(*args)
    finally:
        sys.settrace(before)
    return count


def _mapping(folder: Path, blocks: int) -> Path:
    path = folder / f"map_{blocks}.toml"
    path.write_text(CALIBRATION_STUB + "".join(PARITY_BLOCK.format(i=i)
                                               for i in range(blocks)))
    return path


def test_reading_a_mapping_is_linear_in_its_blocks(tmp_path):
    small, large = _mapping(tmp_path, 50), _mapping(tmp_path, 200)
    read_mapping(small)                       # compiles and caches the regexes once
    assert len(read_mapping(large).sources) == 201
    ratio = _lines_executed(read_mapping, large) / _lines_executed(read_mapping, small)
    assert ratio < LINEAR_RATIO, ratio        # was ~16 (each key's line found by rescanning)


def test_every_block_still_names_its_own_lines(tmp_path):
    m = read_mapping(_mapping(tmp_path, 300))
    last = m.sources[-1]
    header = 6 + 299 * 9 + 2                  # 6 stub lines, then a blank and 8 a block
    assert (last.key, last.line, last.files_line) == ("parity[300]", header, header + 1)
    assert last.columns["shots"].line == header + 7


def test_matching_a_name_is_linear_in_its_length():
    def names(n):
        # every split of the underscores is tried by a backtracking match
        return ["_" * n + ".", "P_" + "_1" * n, "P_red_" + "7" * n]
    for pattern, numeric in (("{sideband}_{n}_{dpd}", {"n", "dpd"}),
                             ("P_{sideband}_{n}", {"n"})):
        ratio = (_lines_executed(matching_keys, pattern, names(4000), numeric)
                 / _lines_executed(matching_keys, pattern, names(1000), numeric))
        assert ratio < LINEAR_RATIO, (pattern, ratio)


def test_names_that_made_backtracking_explode_match_at_once():
    """``{a}_{b}_{c}`` against 5,000 underscores: a regular expression tried every split
    (5,000^3 of them); the guard's 20 s are for a stalled machine, not the expected time."""
    code = textwrap.dedent('''
        from dpdfit.recordings.name_patterns import matching_keys
        n = 5000
        assert matching_keys("{a}_{b}_{c}", ["_" * n + "."], set()) == []
        assert matching_keys("{sideband}_{n}_{dpd}", ["x" + "_1" * n + "_"], {"n", "dpd"}) == []
        got = matching_keys("{a}_{b}_{c}", ["x" + "_" * n + "y"], set())
        assert got == [{"a": "x", "b": "_", "c": "_" * (n - 3) + "y"}], got
        print("matched")
    ''')
    run = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                         text=True, timeout=20)
    assert run.returncode == 0 and run.stdout.strip() == "matched", run.stderr[-2000:]


def test_a_split_is_the_one_a_regular_expression_finds():
    # text placeholders take the shortest text, numbers the longest, as [^.]+? and \d+
    assert match_name("{a}_{b}", "x_y_z", set()) == {"a": "x", "b": "y_z"}
    assert match_name("P_{sideband}_{n}", "P_red_x_-12", {"n"}) == {"sideband": "red_x",
                                                                    "n": "-12"}
    assert match_name("{sideband}{n}", "red12", {"n"}) == {"sideband": "red", "n": "12"}
    assert match_name("{a}_{b}_{c}", "x______y", set()) == {"a": "x", "b": "_", "c": "___y"}
    assert match_name("P_{sideband}_{n}", "P_red.x_1", {"n"}) is None      # no dot in text
    assert match_name("P_{sideband}_{n}", "P_red_1.5", {"n"}) is None
    assert match_name("P_{n}", "P_" + "9" * 19, {"n"}) is None             # beyond int64
    assert match_name("P_{n}", "P_" + "9" * 18, {"n"}) == {"n": "9" * 18}
