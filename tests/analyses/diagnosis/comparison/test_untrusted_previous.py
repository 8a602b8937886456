"""An earlier diagnosis from elsewhere (``dpdfit diagnose --compare PREVIOUS.json``): read
only as a regular file within the JSON bound, and every field the comparison and the
refit of its binding pair read checked before any fit, each refusal one line naming the
file and the key path.

Hang-prone inputs (a FIFO, a device) run the command in a child process with a timeout;
the others run it in this process with the diagnosis replaced by one that fails the test
if it is called: the refusal comes before any fit.  Each refusal: exit 2, one line naming
the file, nothing written, every file of the test's folder unchanged
(:mod:`tests.helpers.untrusted_campaign`).
"""

from __future__ import annotations

import copy
import json
import os

import pytest
from hypothesis import given
from hypothesis import strategies as st

import dpdfit.analyses.diagnosis.diagnose as diagnose_module
from dpdfit.analyses.diagnosis.comparison.compare import compare_diagnoses
from dpdfit.analyses.diagnosis.comparison.previous import read_diagnosis, refit_request
from dpdfit.errors import InputError
from tests.helpers.diagnosis_dicts import after, before
from tests.helpers.paths import ROOT
from tests.helpers.prop_mutations import json_mutations, mutate_json
from tests.helpers.untrusted_campaign import (assert_refused_in_process,
                                              assert_refused_in_subprocess)

CAMP = ROOT / "datasets" / "synthetic_campaign"


@pytest.fixture
def no_fit(monkeypatch):
    """The CLI's diagnosis replaced by one that fails the test: a refusal of the earlier
    diagnosis comes before any fit."""
    def diagnose(*args, **kwargs):
        raise AssertionError("the campaign was diagnosed before the earlier diagnosis "
                             "was checked")
    # the command imports diagnose() when it runs: replaced in its module
    monkeypatch.setattr(diagnose_module, "diagnose", diagnose)


def _refused(capsys, tmp_path, previous, needles):
    """``diagnose CAMP --compare previous --json --plot --schedule``: refused in one line
    naming the file, nothing written, the file unchanged."""
    out = tmp_path / "out"
    out.mkdir()
    line, _ = assert_refused_in_process(
        capsys, ["diagnose", CAMP, "--compare", previous, "--json", "--plot", out / "plots",
                 "--schedule", out / "next.csv"],
        tmp_path, None, [str(previous), *needles])
    assert list(out.iterdir()) == []
    assert line.isprintable()
    return line


def _written(tmp_path, d, name="previous.json"):
    p = tmp_path / name
    p.write_text(json.dumps(d))
    return p


# ----------------------------------------------------------------------------- hangs


def _child(tmp_path, previous, needles, **kw):
    out = tmp_path / "out"
    out.mkdir()
    line, seconds = assert_refused_in_subprocess(["diagnose", CAMP, "--compare", previous,
                                                  "--json", "--plot", out / "plots"],
                                                 tmp_path, None, needles, **kw)
    assert list(out.iterdir()) == []
    assert line.isprintable()
    return line, seconds


def test_a_fifo_is_refused_not_read(tmp_path):
    fifo = tmp_path / "previous.json"
    os.mkfifo(fifo)
    _child(tmp_path, fifo, ["previous.json", "FIFO", "regular files only"])


def test_a_link_to_a_fifo_is_refused_not_read(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    link = tmp_path / "previous.json"
    link.symlink_to(fifo)
    _child(tmp_path, link, ["previous.json", "FIFO"])


def test_standard_input_held_open_is_refused_not_read(tmp_path):
    """``--compare /dev/stdin`` with a pipe whose writer never closes it."""
    r, w = os.pipe()
    try:
        _child(tmp_path, "/dev/stdin", ["/dev/stdin", "FIFO"], stdin=r)
    finally:
        os.close(r)
        os.close(w)


# ----------------------------------------------------------------------------- unbounded


def test_dev_zero_is_refused_not_read(tmp_path):
    _child(tmp_path, "/dev/zero", ["/dev/zero", "character device"])


def test_a_link_to_dev_zero_is_refused_not_read(tmp_path):
    link = tmp_path / "previous.json"
    link.symlink_to("/dev/zero")
    _child(tmp_path, link, ["previous.json", "character device"])


@pytest.mark.parametrize("size", [2**30, 64 * 2**20 + 1])
def test_a_sparse_file_beyond_the_json_bound_is_refused_unread(tmp_path, size):
    """A sparse file of 1 GiB (or one byte over the bound) holds no data on disk; it is
    refused on its size, before a byte is read."""
    p = tmp_path / "previous.json"
    with open(p, "wb") as fh:
        fh.truncate(size)
    line, _ = _child(tmp_path, p, ["previous.json", "64 MiB", "JSON file"])
    assert "1 GiB" in line if size == 2**30 else "67.1 MB" in line


# ----------------------------------------------------------------------------- internal errors


def _with(path: str, value):
    """The earlier diagnosis with the key path ``path`` (dots, list indices as numbers)
    set to ``value``."""
    d = before()
    d["next_measurement"] = copy.deepcopy(d["next_measurement"])
    keys = [int(k) if k.isdigit() else k for k in path.split(".")]
    node = d
    for k in keys[:-1]:
        node = node[k]
    node[keys[-1]] = value
    return d


@pytest.mark.parametrize("path, value, needle", [
    # a form given as a list: refitted, it failed after the whole diagnosis
    ("next_measurement.binding.truth.forms.0", ["aom"],
     "'next_measurement.binding.truth.forms[0]' must be text or null, not a list"),
    ("next_measurement.binding.rival.effects", 7,
     "'next_measurement.binding.rival.effects' must be a list or null, not a number"),
    ("effects", 7, "'effects' must be a list, not a number"),
    ("ranking.1.effect", ["spam_offset"], "'ranking[1].effect' must be text, not a list"),
    ("alternatives.0.named", [1, 2], "'alternatives[0].named[0]' must be text, not a number"),
    ("next_measurement.binding.truth.chi2", 10**400,
     ("'next_measurement.binding.truth.chi2' must be a number or null, not a number beyond "
      "a float's range")),
    ("next_measurement.binding.truth.chi2", "100",
     "'next_measurement.binding.truth.chi2' must be a number or null, not text"),
    ("next_measurement.settings", [0.85], "'next_measurement.settings' must be an object"),
    ("next_measurement.decisive", "yes", "'next_measurement.decisive' must be true or false"),
    ("verdict", None, "'verdict' must be text, not null"),
])
def test_a_field_of_another_type_is_refused_with_its_key_path(tmp_path, capsys, no_fit,
                                                              path, value, needle):
    _refused(capsys, tmp_path, _written(tmp_path, _with(path, value)), [needle])


@pytest.mark.parametrize("where", ["next_measurement.settings.amplitudes", "extra"])
def test_json_the_comparison_could_not_walk_is_refused_before_any_fit(tmp_path, capsys,
                                                                      no_fit, where):
    """500 levels in a key the checks do not read: parsed, it stopped the comparison
    (to_jsonable) after the whole diagnosis with a RecursionError naming no file."""
    deep = json.loads("[" * 500 + "]" * 500)
    d = _with(where, deep) if where != "extra" else {**before(), "extra": deep}
    _refused(capsys, tmp_path, _written(tmp_path, d),
             ["nested too deeply", "more than 64 levels"])


# ----------------------------------------------------------------------------- silent acceptance


@pytest.mark.parametrize("path, value, needle", [
    # zip() paired the effects with fewer forms: an effect was left out of the refit
    ("next_measurement.binding.truth.forms", [],
     "'next_measurement.binding.truth.forms' holds 0 forms for 1 effects"),
    # entries that are not objects, or lack their effect, were skipped without a word
    ("effects.0", "stale_calibration", "'effects[0]' must be an object, not text"),
    ("ranking.0", {"delta_bic": -80.0}, "'ranking[0]' has no 'effect'"),
    ("alternatives.2", 3, "'alternatives[2]' must be an object, not a number"),
])
def test_what_was_skipped_or_truncated_is_refused(tmp_path, capsys, no_fit, path, value,
                                                  needle):
    _refused(capsys, tmp_path, _written(tmp_path, _with(path, value)), [needle])


# ----------------------------------------------------------------------------- unclear lines


def test_nesting_too_deep_names_the_file(tmp_path, capsys, no_fit):
    p = tmp_path / "previous.json"
    p.write_text("[" * 100_000 + "]" * 100_000)
    _refused(capsys, tmp_path, p, ["nested too deeply"])


def test_a_file_name_with_an_escape_sequence_is_printed_escaped(tmp_path, capsys, no_fit):
    p = _written(tmp_path, _with("verdict", 3), name="prev\x1b[2J\x1b[31m.json")
    line, _ = assert_refused_in_process(capsys, ["diagnose", CAMP, "--compare", p, "--json"],
                                        tmp_path, None,
                                        ["prev\\x1b[2J\\x1b[31m.json",
                                         "'verdict' must be text"])
    assert "\x1b" not in line


def test_a_key_path_is_shown_not_the_value(tmp_path, capsys, no_fit):
    """A value is described by its kind: a crafted one (control characters, a numpy
    repr's look) never reaches the line."""
    evil = "\x1b]0;pwned\x07np.float64(3)"
    line = _refused(capsys, tmp_path,
                    _written(tmp_path, _with("next_measurement.binding.truth.forms.0", [evil])),
                    ["forms[0]' must be text or null, not a list"])
    assert "pwned" not in line and "np.float64" not in line


def test_the_report_prints_the_earlier_diagnosis_text_escaped():
    """Accepted text (a verdict, a reason) is printed with its control characters
    escaped: the report cannot drive the terminal."""
    d = before()
    d["verdict"] = "stale\x1b[31m_calibration"
    d["next_measurement"] = {"what": None, "reason": "none\r\x1b[2Kgone"}
    text = compare_diagnoses(d, after()).report()
    assert "\x1b" not in text and "\r" not in text
    assert "stale\\x1b[31m_calibration" in text and "none\\r\\x1b[2Kgone" in text
    assert all(line.isprintable() for line in text.splitlines())


def test_a_diagnosis_as_dpdfit_writes_it_is_compared_as_before(tmp_path):
    """The checks take nothing from a diagnosis as dpdfit writes it."""
    p = _written(tmp_path, before())
    assert read_diagnosis(p) == before()
    assert refit_request(read_diagnosis(p)) == [
        {"effects": ["stale_calibration"], "forms": ["aom"]},
        {"effects": ["detector_nonlinearity"], "forms": ["linear"]}]
    assert compare_diagnoses(p, after()).to_dict() == compare_diagnoses(before(),
                                                                        after()).to_dict()


# ----------------------------------------------------------------------------- property


_NASTY = st.one_of(st.sampled_from([[["aom"]], {"a": 1}, 10**400, "\x1b[31m", [None], [[]],
                                    float("nan"), float("inf"), True, "", [1, "a"]]),
                   st.text(max_size=4), st.lists(st.integers(), max_size=2))


@given(ops=json_mutations(max_ops=4), extra=st.lists(st.tuples(st.integers(0, 10**6),
                                                                _NASTY), max_size=2))
def test_a_mutated_earlier_diagnosis_is_compared_or_refused_in_one_line(tmp_path_factory,
                                                                         ops, extra):
    """Any mutation of an earlier diagnosis's JSON: read_diagnosis, refit_request and
    compare_diagnoses (with its report and JSON) either work or raise one InputError
    line naming the file, nothing else."""
    ops = list(ops) + [("set", i, v) for i, v in extra]
    p = tmp_path_factory.mktemp("prev") / "previous.json"
    p.write_bytes(mutate_json(before(), ops))
    try:
        d = read_diagnosis(p)
        refit_request(d)
        c = compare_diagnoses(d, after())
        json.dumps(c.to_dict(), allow_nan=True)
        assert all(line.isprintable() for line in c.report().splitlines())
    except InputError as exc:
        msg = str(exc)
        assert str(p) in msg and msg.isprintable(), msg
