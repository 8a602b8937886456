"""Single files a command is given from elsewhere -- a schedule (``write-artiq-results
--schedule``), an import mapping, a ``calibration.json``, a budget config, a harness truth
file or run log, a simulated campaign's ``truth.json`` -- read through the one reader
(:mod:`dpdfit.recordings.input_files`): a FIFO, a device or a file beyond its bound is
refused unread, a file nested too deeply is refused naming it.

Each refusal: exit 2, one ``dpdfit: error:`` line on stderr naming the file, never a
traceback or the internal-error line, nothing written, every file of the test's folder
unchanged (:mod:`tests.helpers.untrusted_campaign`).  What could hang (a FIFO, a device,
a file that fills the memory) runs in a child process with a timeout.
"""

from __future__ import annotations

import os
import shutil

import pytest

from dpdfit.core.defaults import MAX_SCHEDULE_ROWS
from tests.helpers.bundled_data import CAMPAIGN
from tests.helpers.small_artiq_lab import SMALL_MAPPING, write_small_lab
from tests.helpers.untrusted_campaign import (assert_refused_in_process,
                                              assert_refused_in_subprocess, small_campaign)

SCHEDULE = ("kind,repeat,point,A,dpd,shots,phase_rad,t_us,lab_s\n"
            "populations,1,0,0.5,1,625,,,6.25\n")
#: nested deeper than any parser of dpdfit's reads (Python's stack ends near a thousand)
DEEP_JSON = "[" * 100_000 + "]" * 100_000


def _fifo(path):
    os.mkfifo(path)
    return path


def _sparse(path, size):
    with open(path, "wb") as fh:
        fh.truncate(size)
    return path


def _record(schedule, tmp_path, campaign=CAMPAIGN):
    """``write-artiq-results CAMPAIGN tmp/lab --schedule schedule``."""
    return ["write-artiq-results", campaign, tmp_path / "lab", "--schedule", schedule]


def _simulated_campaign(tmp_path, truth_text: str):
    """The bundled campaign's tables beside a ``truth.json`` holding ``truth_text``, and a
    schedule it could record."""
    folder = small_campaign(tmp_path)
    (folder / "truth.json").write_text(truth_text)
    schedule = tmp_path / "schedule.csv"
    schedule.write_text(SCHEDULE)
    return folder, schedule


def _mapping_test(tmp_path, mapping):
    return ["import", mapping, "-o", tmp_path / "imported"]


# ----------------------------------------------------------------------------- hangs


@pytest.mark.parametrize("case", ["schedule", "schedule link", "mapping", "calibration",
                                  "harness truth", "campaign truth", "harness log"])
def test_a_fifo_is_refused_unread(tmp_path, case):
    pipe = _fifo(tmp_path / {"schedule": "schedule.csv", "schedule link": "pipe",
                             "mapping": "map.toml", "calibration": "calibration.json",
                             "harness truth": "truth.json", "campaign truth": "pipe",
                             "harness log": "runs.jsonl"}[case])
    named, output = pipe.name, tmp_path / "lab"
    if case == "schedule":
        argv = _record(pipe, tmp_path)
    elif case == "schedule link":
        (tmp_path / "schedule.csv").symlink_to(pipe)
        argv, named = _record(tmp_path / "schedule.csv", tmp_path), "schedule.csv"
    elif case == "campaign truth":
        folder, schedule = _simulated_campaign(tmp_path, "{}")
        (folder / "truth.json").unlink()
        os.rename(pipe, folder / "truth.json")
        argv, named = _record(schedule, tmp_path, folder), "truth.json"
    elif case == "harness log":
        argv, output = ["harness", "--per-effect", "1", "--nulls", "0", "--log", pipe], None
    else:
        argv, output = _command(case, pipe, tmp_path)
    assert_refused_in_subprocess(argv, tmp_path, output,
                                 [named, "FIFO", "regular files only"])


def test_standard_input_held_open_as_the_schedule_is_refused_unread(tmp_path):
    """``--schedule /dev/stdin`` with a pipe whose writer never closes it."""
    r, w = os.pipe()
    try:
        assert_refused_in_subprocess(_record("/dev/stdin", tmp_path), tmp_path,
                                     tmp_path / "lab", ["/dev/stdin", "FIFO"], stdin=r)
    finally:
        os.close(r)
        os.close(w)


# ----------------------------------------------------------------------------- unbounded


def test_dev_zero_as_the_schedule_is_refused_unread(tmp_path):
    assert_refused_in_subprocess(_record("/dev/zero", tmp_path), tmp_path, tmp_path / "lab",
                                 ["/dev/zero", "character device"])


def test_a_sparse_schedule_beyond_the_input_bound_is_refused_unread(tmp_path):
    p = _sparse(tmp_path / "schedule.csv", 2 * 2**30)
    assert_refused_in_subprocess(_record(p, tmp_path), tmp_path, tmp_path / "lab",
                                 ["schedule.csv", "2 GiB, more than the 1 GiB",
                                  "DPDFIT_MAX_INPUT_BYTES"])


def test_a_schedule_beyond_its_rows_is_refused_before_the_rest_is_read(tmp_path):
    """One row more than a schedule holds, then a sparse gigabyte (less one byte, within
    the input bound): refused at the row, the gigabyte unread."""
    p = tmp_path / "schedule.csv"
    p.write_text(SCHEDULE.splitlines()[0] + "\n" + "".join(
        f"amplitude_run,1,{i},0.5,,,,,1.0\n" for i in range(MAX_SCHEDULE_ROWS + 1)))
    with open(p, "r+b") as fh:
        fh.truncate(2**30)
    assert_refused_in_subprocess(_record(p, tmp_path), tmp_path, tmp_path / "lab",
                                 ["schedule.csv", f"more than {MAX_SCHEDULE_ROWS} rows",
                                  "the rest of it was not read"])


def _command(kind, path, tmp_path):
    """(argv, output) of the command that reads ``path`` as a file of ``kind``."""
    if kind == "mapping":
        return _mapping_test(tmp_path, path), tmp_path / "imported"
    if kind == "calibration":
        return ["lut", path, "-o", tmp_path / "lut.csv"], tmp_path / "lut.csv"
    return ["harness", "--campaigns", CAMPAIGN.parent, "--truth", path], None


@pytest.mark.parametrize("kind, name, size, needle", [
    ("mapping", "map.toml", None, "character device"),
    ("mapping", "map.toml", 2 * 2**30, "2 GiB, more than the 1 GiB"),
    ("calibration", "calibration.json", None, "character device"),
    ("calibration", "calibration.json", 2**30, "1 GiB, more than the 64 MiB"),
    ("harness truth", "truth.json", None, "character device"),
    ("harness truth", "truth.json", 2**30, "1 GiB, more than the 64 MiB"),
])
def test_a_device_or_sparse_file_is_refused_unread(tmp_path, kind, name, size, needle):
    """A link to /dev/zero (size None), or a sparse file of ``size`` bytes."""
    p = tmp_path / name
    if size is None:
        p.symlink_to("/dev/zero")
    else:
        _sparse(p, size)
    argv, output = _command(kind, p, tmp_path)
    assert_refused_in_subprocess(argv, tmp_path, output, [name, needle])


# ----------------------------------------------------------------------------- internal errors


def test_a_truth_json_walked_too_deep_is_refused_before_the_simulation(tmp_path, capsys):
    """A truth.json the parser reads (500 levels) but the config's reading recursed
    through: refused by its depth, naming the file."""
    folder, schedule = _simulated_campaign(
        tmp_path, '{"config": {"further": ' + "[" * 500 + "]" * 500 + "}}")
    assert_refused_in_process(capsys, _record(schedule, tmp_path, folder), tmp_path,
                              tmp_path / "lab", ["truth.json", "nested too deeply",
                                                 "more than 64 levels"])


def test_a_harness_log_line_nested_too_deeply_is_not_a_run_record(tmp_path, capsys):
    log = tmp_path / "runs.jsonl"
    log.write_text(DEEP_JSON + "\n")
    assert_refused_in_process(capsys, ["harness", "--per-effect", "1", "--nulls", "0",
                                       "--log", log], tmp_path, None,
                              ["runs.jsonl, line 1: not a harness run record"])


def test_a_harness_truth_walked_too_deep_is_refused_naming_it(tmp_path, capsys):
    truth = tmp_path / "truth.json"
    truth.write_text('{"v01": {"effect": "none", "x": ' + "[" * 400 + "]" * 400 + "}}")
    assert_refused_in_process(capsys, ["harness", "--campaigns", CAMPAIGN.parent,
                                       "--truth", truth], tmp_path, None,
                              ["truth.json", "nested too deeply"])


# ----------------------------------------------------------------------------- unclear lines


@pytest.mark.parametrize("case", ["calibration", "budget config", "harness truth",
                                  "campaign truth", "mapping"])
def test_nesting_too_deep_for_the_parser_names_the_file(tmp_path, capsys, case):
    """Before, a RecursionError from the parser reached the command line's last line of
    defence: "input nested too deeply for 'dpdfit lut'", naming no file."""
    output = None
    if case in ("calibration", "harness truth"):
        p = tmp_path / ("calibration.json" if case == "calibration" else "truth.json")
        p.write_text(DEEP_JSON)
        argv, output = _command(case, p, tmp_path)
    elif case == "budget config":
        p = tmp_path / "budget.toml"
        p.write_text("[costs]\nx = " + DEEP_JSON + "\n")
        argv = ["budget", "--config", p]
    elif case == "campaign truth":
        folder, schedule = _simulated_campaign(tmp_path, DEEP_JSON)
        p = folder / "truth.json"
        argv, output = _record(schedule, tmp_path, folder), tmp_path / "lab"
    else:
        p = tmp_path / "map.toml"
        p.write_text(SMALL_MAPPING + "[import]\nx = " + DEEP_JSON + "\n")
        argv, output = _command("mapping", p, tmp_path)
    line, _ = assert_refused_in_process(capsys, argv, tmp_path, output,
                                        [str(p), "nested too deeply"])
    assert "input nested too deeply for" not in line


def test_a_campaign_table_of_write_artiq_results_is_read_only_inside_the_campaign(tmp_path,
                                                                                  capsys):
    """write-artiq-results reads the campaign's tables through the reader too: a table
    linked to a file outside the campaign is refused, its text never shown."""
    folder = small_campaign(tmp_path)
    shutil.copy(CAMPAIGN / "truth.json", folder / "truth.json")
    (folder / "spectra.csv").unlink()
    (folder / "spectra.csv").symlink_to(tmp_path / "outside" / "secret.csv")
    assert_refused_in_process(capsys, ["write-artiq-results", folder, tmp_path / "lab"],
                              tmp_path, tmp_path / "lab",
                              ["spectra.csv", "leads out of"])


def test_an_earlier_import_with_a_fifo_for_campaign_json_is_not_replaced(tmp_path, capsys):
    """``analyze MAP.toml -o OUT`` replaces OUT/imported_campaign only when it is an
    earlier import: a FIFO as its campaign.json makes it none (read, it hung)."""
    target = tmp_path / "out" / "imported_campaign"
    target.mkdir(parents=True)
    _fifo(target / "campaign.json")
    mapping = tmp_path / "map.toml"
    mapping.write_text(SMALL_MAPPING)
    write_small_lab(tmp_path)
    assert_refused_in_subprocess(["analyze", mapping, "-o", tmp_path / "out"], tmp_path,
                                 None, ["imported_campaign",
                                        "is not a campaign dpdfit imported"])


_SWEEP_COLUMNS = ("A,dpd,sideband,P0_dB,P1_dB,P2_dB,P3_dB,R10_dB,R23_dB,dP1_dB,dP2_dB,eta_bar,"
                  "F_est,eps_est,r_rel")


@pytest.mark.parametrize("value, needle", [
    ("[0.5, 0.6]", "the header's A_corr must be a number in (0, 1], got a list"),
    ('"0.56"', "the header's A_corr must be a number in (0, 1], got text"),
    ('{"value": 0.56}', "the header's A_corr must be a number in (0, 1], got an object"),
    ("-0.5", "the header's A_corr must be a number in (0, 1], got -0.5"),
    (DEEP_JSON, "a '# key: value' header line is nested too deeply"),
])
def test_a_sweep_header_that_dpdfit_does_not_write_is_refused(tmp_path, capsys, value,
                                                                needle):
    """The sweep file's ``# A_corr:`` header line is JSON: a value of another kind reached
    float() in ``thresholds`` (the internal-error line), one nested too deeply the
    command line's last line of defence (naming no file)."""
    sweep = tmp_path / "sweep.csv"
    sweep.write_text(f"# A_corr: {value}\n{_SWEEP_COLUMNS}\n"
                     + "".join(f"{a},{d},red" + ",1" * 12 + "\n"
                               for a in (0.2, 0.4, 0.6, 0.8) for d in (0, 1)))
    assert_refused_in_process(capsys, ["thresholds", sweep], tmp_path, None,
                              ["sweep.csv", needle])
