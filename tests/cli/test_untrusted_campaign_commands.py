"""``dpdfit analyze`` and ``dpdfit diagnose`` on a campaign folder crafted or damaged
elsewhere: each case is refused in one line with exit 2, before any fit, nothing written
and every input unchanged (:mod:`tests.helpers.untrusted_campaign`).

The cases are grouped by what would go wrong without the refusal: a file outside the
folder read (its text printed), a read that never ends, memory or time without bound,
a malformed table taken as if it were sound, the internal-error line, a line that does
not say where the problem is or drives the terminal.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from tests.helpers.untrusted_campaign import (
    assert_refused_in_process, assert_refused_in_subprocess, declaring_npy_bytes,
    list_traces, small_campaign, write_declaring_npz)


def _analyze(camp, out):
    return ["analyze", camp, "-o", out, "--no-diagnosis", "--no-plots"]


def _diagnose(camp, out):
    return ["diagnose", camp, "--plot", out]


def _replace(path, make):
    path.unlink()
    make(path)


def _link_out(target):
    return lambda path: os.symlink(target, path)


def _edit_line(path, number, edit):
    """Line ``number`` (1-based) of the text file ``path`` as ``edit`` makes it."""
    lines = path.read_text().splitlines(keepends=True)
    lines[number - 1] = edit(lines[number - 1].rstrip("\n")) + "\n"
    path.write_text("".join(lines))


def _replace_cell(path, line, column, text):
    def edit(row):
        cells = row.split(",")
        cells[column] = text
        return ",".join(cells)
    _edit_line(path, line, edit)


def _trace_archive_damaged(path):
    np.savez_compressed(path, trace=np.random.default_rng(0).normal(size=20_000))
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0xFF
    path.write_bytes(bytes(data))


# ----------------------------------------------------------------------------- leaks
# A link or a listed path leading out of the folder is refused before a byte of the
# file it leads to is read: the secret appears neither on stderr nor in any output.

LEAKS = {
    "spectra.csv linked to a secret outside": (
        _analyze, lambda c, o: _replace(c / "spectra.csv", _link_out(o / "secret.csv")),
        ["spectra.csv", "leads out of"]),
    "traces.csv listing ../outside/secret.csv": (
        _analyze, lambda c, o: list_traces(c, "../outside/secret.csv"),
        ["traces.csv", "column 'file', row 1", "leads out of", "(line 2)"]),
    "traces.csv listing the secret's absolute path": (
        _analyze, lambda c, o: list_traces(c, str(o / "secret.csv")),
        ["traces.csv", "row 1", "leads out of"]),
    "campaign.json linked to a secret outside": (
        _diagnose, lambda c, o: _replace(c / "campaign.json", _link_out(o / "secret.json")),
        ["campaign.json", "leads out of"]),
    "budget.toml linked to a secret outside": (
        _analyze, lambda c, o: os.symlink(o / "secret.toml", c / "budget.toml"),
        ["budget.toml", "leads out of"]),
}


@pytest.mark.parametrize("case", list(LEAKS))
def test_no_file_outside_the_campaign_is_read(tmp_path, capsys, case):
    command, craft, needles = LEAKS[case]
    camp = small_campaign(tmp_path)
    craft(camp, tmp_path / "outside")
    out = tmp_path / "results"
    assert_refused_in_process(capsys, command(camp, out), tmp_path, out, needles)


# ----------------------------------------------------------------------------- hangs
# A FIFO blocks a reader forever: refused on its type, never opened for reading.  Run in
# a child process, killed by the guard's timeout should it hang.

def _fifo(path):
    os.mkfifo(path)


HANGS = {
    "spectra.csv a FIFO": (
        _analyze, lambda c: _replace(c / "spectra.csv", _fifo), ["spectra.csv", "FIFO"]),
    "campaign.json a FIFO": (
        _diagnose, lambda c: _replace(c / "campaign.json", _fifo), ["campaign.json", "FIFO"]),
    "a listed trace a FIFO": (
        _analyze, lambda c: ((c / "traces").mkdir(), _fifo(c / "traces" / "t.npz"),
                             list_traces(c, "traces/t.npz")),
        ["traces.csv", "row 1", "t.npz", "FIFO"]),
    "the campaign argument a FIFO": (
        lambda c, o: ["diagnose", c.parent / "pipe", "--plot", o],
        lambda c: _fifo(c.parent / "pipe"), ["pipe", "FIFO", "not a campaign folder"]),
}


@pytest.mark.parametrize("case", list(HANGS))
def test_a_fifo_is_refused_without_blocking(tmp_path, case):
    command, craft, needles = HANGS[case]
    camp = small_campaign(tmp_path)
    craft(camp)
    out = tmp_path / "results"
    assert_refused_in_subprocess(command(camp, out), tmp_path, out, needles)


# ------------------------------------------------------------------- unbounded memory
# A file, or an array a file declares, beyond the bound is refused from its size or
# header, before it is read; a table wider than MAX_CSV_COLUMNS before pandas builds it.

def _sparse(size):
    def make(path):
        with open(path, "wb") as fh:
            fh.truncate(size)
    return make


def _wide_header(path):
    path.write_text(",".join(f"c{i}" for i in range(300_008)) + "\n1\n")


def _wide_row(path):
    with open(path, "a") as fh:
        fh.write(",".join(["1"] * 300_008) + "\n")


def _declaring_npz(camp):
    (camp / "traces").mkdir()
    write_declaring_npz(camp / "traces" / "t.npz", 200_000_000)
    list_traces(camp, "traces/t.npz")


def _declaring_npy(camp):
    (camp / "traces").mkdir()
    (camp / "traces" / "t.npy").write_bytes(declaring_npy_bytes(200_000_000))
    list_traces(camp, "traces/t.npy")


UNBOUNDED = {
    "calibration_amplitude.csv a sparse file of 3 GiB": (
        _analyze, lambda c: _replace(c / "calibration_amplitude.csv", _sparse(3 * 2**30)),
        ["calibration_amplitude.csv", "is 3 GiB", "more than the 1 GiB",
         "DPDFIT_MAX_INPUT_BYTES"]),
    "a sparse table under the bound (zeros, not text)": (
        _diagnose, lambda c: _replace(c / "parity.csv", _sparse(4 * 2**20)),
        ["parity.csv", "NUL byte (byte 1)"]),
    "a header of 300,008 fields": (
        _analyze, lambda c: _wide_header(c / "gate_rates.csv"),
        ["gate_rates.csv", "header (line 1) has 300008 fields", "1000 columns"]),
    "a row of 300,008 fields": (
        _analyze, lambda c: _wide_row(c / "gate_rates.csv"),
        ["gate_rates.csv", "row 11", "300008 fields, the header 4", "(line 12)"]),
    "a 1 kB .npz declaring 2e8 samples": (
        _analyze, _declaring_npz,
        ["traces.csv", "row 1", "t.npz", "declares 200,000,000 samples", "1 GiB"]),
    "a .npy declaring 2e8 samples": (
        _diagnose, _declaring_npy, ["traces.csv", "t.npy", "declares 200,000,000 samples"]),
}


@pytest.mark.parametrize("case", list(UNBOUNDED))
def test_a_file_beyond_the_bounds_is_refused_before_it_is_read(tmp_path, capsys, case):
    command, craft, needles = UNBOUNDED[case]
    camp = small_campaign(tmp_path)
    craft(camp)
    out = tmp_path / "results"
    assert_refused_in_process(capsys, command(camp, out), tmp_path, out, needles)


def test_the_bound_is_the_one_set_for_the_run(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("DPDFIT_MAX_INPUT_BYTES", "1000000")
    camp = small_campaign(tmp_path)
    _replace(camp / "parity.csv", _sparse(8 * 2**20))
    out = tmp_path / "results"
    assert_refused_in_process(capsys, _analyze(camp, out), tmp_path, out,
                              ["parity.csv", "is 8 MiB, more than the 1 MB"])


def test_dev_zero_as_campaign_json_is_not_read(tmp_path):
    camp = small_campaign(tmp_path)
    _replace(camp / "campaign.json", _link_out("/dev/zero"))
    out = tmp_path / "results"
    assert_refused_in_subprocess(_diagnose(camp, out), tmp_path, out,
                                 ["campaign.json", "leads out of"])


# ---------------------------------------------------------------- silent acceptance
# pandas would rename a repeated column 'A.1', drop a field or take the first column as
# the index; a spreadsheet opening dpdfit's outputs would run a formula cell.

SILENT = {
    "a column named twice": (
        _analyze, lambda c: _edit_line(c / "populations.csv", 1,
                                       lambda h: h.replace("A,dpd,", "A,A,")),
        ["populations.csv", "column 'A'", "named twice in the header (columns 1 and 2)"]),
    "every row a field more than the header": (
        _analyze, lambda c: [_edit_line(c / "gate_rates.csv", n, lambda r: r + ",1")
                             for n in range(2, 12)],
        ["gate_rates.csv", "row 1", "5 fields, the header 4", "(line 2)"]),
    "one row in the middle a field more": (
        _diagnose, lambda c: _edit_line(c / "spectra.csv", 8, lambda r: r + ",9"),
        ["spectra.csv", "row 7", "8 fields, the header 7", "(line 8)"]),
    "a run label =cmd formula": (
        _analyze, lambda c: _replace_cell(c / "calibration_amplitude.csv", 4, 0,
                                          "=cmd|' /C calc'!A0"),
        ["calibration_amplitude.csv", "column 'run', row 3", "starts with '='",
         "(line 4)"]),
    "a scan label @ formula": (
        _diagnose, lambda c: _replace_cell(c / "populations.csv", 3, 2,
                                           "@SUM(1+1)*cmd|' /C calc'!A0"),
        ["populations.csv", "column 'scan', row 2", "starts with '@'"]),
    "a rate that starts like a negative number": (
        _analyze, lambda c: _replace_cell(c / "gate_rates.csv", 5, 2,
                                          "-2+3+cmd|' /C calc'!A0"),
        ["gate_rates.csv", "column 'xi0_khz', row 4", "starts with '-'"]),
    "spectra.csv a symbolic link loop (it read as absent)": (
        _analyze, lambda c: (os.remove(c / "spectra.csv"),
                             os.symlink("spectra.csv", c / "spectra.csv")),
        ["spectra.csv", "symbolic link loop"]),
}


@pytest.mark.parametrize("case", list(SILENT))
def test_a_malformed_table_is_not_taken_as_sound(tmp_path, capsys, case):
    command, craft, needles = SILENT[case]
    camp = small_campaign(tmp_path)
    craft(camp)
    out = tmp_path / "results"
    assert_refused_in_process(capsys, command(camp, out), tmp_path, out, needles)


# ----------------------------------------------------------------- internal errors
# Each of these ended in "internal error while running ...".

def _loop(folder, name):
    os.symlink(folder / f"{name}_b", folder / name)
    os.symlink(folder / name, folder / f"{name}_b")
    return folder / name


def test_diagnose_a_campaign_argument_that_is_a_link_loop(tmp_path, capsys):
    small_campaign(tmp_path)
    loop = _loop(tmp_path, "loop")
    schedule = tmp_path / "schedule.csv"
    assert_refused_in_process(capsys, ["diagnose", loop, "--schedule", schedule], tmp_path,
                              schedule, ["loop", "symbolic link loop", "not a campaign"])


def test_analyze_into_a_results_folder_that_is_a_link_loop(tmp_path, capsys):
    camp = small_campaign(tmp_path)
    loop = _loop(tmp_path, "results")
    assert_refused_in_process(capsys, _analyze(camp, loop), tmp_path, None,
                              ["results", "results folder", "symbolic link loop"])


def test_diagnose_a_schedule_that_is_a_link_loop(tmp_path, capsys):
    camp = small_campaign(tmp_path)
    loop = _loop(tmp_path, "schedule.csv")
    assert_refused_in_process(capsys, ["diagnose", camp, "--schedule", loop], tmp_path,
                              None, ["schedule.csv", "schedule file", "symbolic link loop"])


def test_analyze_a_listed_trace_archive_damaged(tmp_path, capsys):
    camp = small_campaign(tmp_path)
    (camp / "traces").mkdir()
    _trace_archive_damaged(camp / "traces" / "t.npz")
    list_traces(camp, "traces/t.npz")
    out = tmp_path / "results"
    assert_refused_in_process(capsys, _analyze(camp, out), tmp_path, out,
                              ["traces.csv", "row 1", "not a readable .npz archive",
                               "Bad CRC-32"])


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads a folder of mode 000")
def test_analyze_a_campaign_folder_that_cannot_be_read(tmp_path, capsys):
    camp = small_campaign(tmp_path)
    out = tmp_path / "results"
    camp.chmod(0)
    try:
        assert_refused_in_process(capsys, _analyze(camp, out), tmp_path / "outside", out,
                                  ["campaign", "cannot be read"])
    finally:
        camp.chmod(0o755)


# ---------------------------------------------------------------------- unclear lines
# The file, column and row named; printable characters only.

def test_campaign_json_nested_too_deeply_is_named(tmp_path, capsys):
    camp = small_campaign(tmp_path)
    (camp / "campaign.json").write_text("[" * 200_000)
    out = tmp_path / "results"
    assert_refused_in_process(capsys, _analyze(camp, out), tmp_path, out,
                              ["campaign.json", "nested too deeply"])


def test_a_row_wider_than_its_header_is_named_by_row_and_line(tmp_path, capsys):
    camp = small_campaign(tmp_path)
    _edit_line(camp / "parity.csv", 21, lambda r: r + ",7")
    out = tmp_path / "results"
    line, _ = assert_refused_in_process(capsys, _analyze(camp, out), tmp_path, out,
                                        ["parity.csv", "row 20", "(line 21)",
                                         "7 fields, the header 6"])
    assert "C error" not in line and "tokenizing" not in line


def test_a_column_name_with_an_escape_sequence_is_shown_escaped(tmp_path, capsys):
    camp = small_campaign(tmp_path)
    _edit_line(camp / "populations.csv", 1,
               lambda h: h.replace("scan,n00", "\x1b[2J\x1b[31mscan,\x1b[2J\x1b[31mscan"))
    out = tmp_path / "results"
    assert_refused_in_process(capsys, _analyze(camp, out), tmp_path, out,
                              ["populations.csv", "column '\\x1b[2J\\x1b[31mscan'",
                               "named twice"])


def test_a_listed_path_with_control_characters_is_shown_escaped(tmp_path, capsys):
    camp = small_campaign(tmp_path)
    list_traces(camp, "../\x1b]0;owned\x07/x.npz")
    out = tmp_path / "results"
    assert_refused_in_process(capsys, _analyze(camp, out), tmp_path, out,
                              ["traces.csv", "row 1", "\\x1b]0;owned\\x07", "leads out of"])
