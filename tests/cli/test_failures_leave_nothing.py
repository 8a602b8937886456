"""Whatever goes wrong, the command line prints one line and leaves nothing behind.

An exception no check turned into a message of its own is the last line of defence's
one line (a bug to report, its traceback logged at DEBUG), not a traceback; a failed
import removes the folders it made for its output, and an output folder that existed
keeps its mode."""

from __future__ import annotations

import logging
import os
import stat
import sys

import pytest

pytest.importorskip("h5py")

import dpdfit.cli.import_campaign as import_cli  # noqa: E402
from dpdfit.cli.main import INTERNAL_ERROR, OUT_OF_MEMORY, TOO_DEEP, main  # noqa: E402
from dpdfit.errors import InputError  # noqa: E402
from dpdfit.recordings.campaign_import import ImportedCampaign  # noqa: E402
from tests.helpers.small_artiq_lab import SMALL_MAPPING, write_small_lab  # noqa: E402

posix = pytest.mark.skipif(sys.platform == "win32", reason="POSIX modes")


@pytest.fixture
def lab(tmp_path):
    folder = tmp_path / "lab"
    write_small_lab(folder)
    (folder / "map.toml").write_text(SMALL_MAPPING)
    return folder


def _one_line(capsys, code):
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.count("\n") == 1 and err.startswith("dpdfit: error: "), err
    return err.rstrip("\n")


def _raising(exc):
    def command(args):
        raise exc
    return command


@pytest.mark.parametrize("exc, shown", [
    (KeyError("axes"), "KeyError: 'axes'"),
    (TypeError("'int' object is not subscriptable"),
     "TypeError: 'int' object is not subscriptable"),
    (ValueError("two\nlines"), "ValueError: two lines"),
    (ZeroDivisionError(), "ZeroDivisionError"),
])
def test_an_unexpected_exception_is_one_line_naming_it_as_a_bug(exc, shown, lab, tmp_path,
                                                                capsys, monkeypatch):
    monkeypatch.setattr(import_cli, "cmd_import", _raising(exc))
    line = _one_line(capsys, main(["import", str(lab / "map.toml"), "-o", str(tmp_path / "c")]))
    assert line == (f"dpdfit: error: {INTERNAL_ERROR} while running 'dpdfit import' ({shown}): "
                    "a bug in dpdfit; please report it with the command and its inputs")


def test_a_long_exception_message_is_cut(lab, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(import_cli, "cmd_import", _raising(RuntimeError("x" * 5000)))
    line = _one_line(capsys, main(["import", str(lab / "map.toml"), "-o", str(tmp_path / "c")]))
    assert f"(RuntimeError: {'x' * 300}...)" in line and "x" * 301 not in line


def test_the_traceback_is_logged_at_debug_level(lab, tmp_path, capsys, monkeypatch, caplog):
    monkeypatch.setattr(import_cli, "cmd_import", _raising(KeyError("axes")))
    with caplog.at_level(logging.DEBUG, logger="dpdfit.cli.main"):
        main(["import", str(lab / "map.toml"), "-o", str(tmp_path / "c")])
    logged = [r for r in caplog.records if r.name == "dpdfit.cli.main"]
    assert len(logged) == 1 and logged[0].levelno == logging.DEBUG
    assert logged[0].exc_info[0] is KeyError
    _one_line(capsys, 2)


@pytest.mark.parametrize("exc, start", [
    (MemoryError("Unable to allocate 8.00 EiB for an array"),
     f"{OUT_OF_MEMORY} while running 'dpdfit import' (MemoryError: Unable to allocate 8.00 EiB"),
    (RecursionError("maximum recursion depth exceeded"),
     f"{TOO_DEEP} for 'dpdfit import' (RecursionError: maximum recursion depth exceeded)"),
])
def test_memory_and_recursion_exhausted_are_one_line(exc, start, lab, tmp_path, capsys,
                                                     monkeypatch):
    monkeypatch.setattr(import_cli, "cmd_import", _raising(exc))
    line = _one_line(capsys, main(["import", str(lab / "map.toml"), "-o", str(tmp_path / "c")]))
    assert line.startswith(f"dpdfit: error: {start}"), line


def test_an_os_error_without_a_file_name_is_its_text(lab, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(import_cli, "cmd_import", _raising(OSError(28, "No space left on device")))
    line = _one_line(capsys, main(["import", str(lab / "map.toml"), "-o", str(tmp_path / "c")]))
    assert line == "dpdfit: error: No space left on device"


# ------------------------------------------------------------------ nothing left behind
def _entries(folder):
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*"))


@pytest.mark.parametrize("failure", [KeyError("late"), InputError("refused", file="x.h5")])
def test_a_failed_import_removes_the_folders_it_made_and_only_those(failure, lab, tmp_path,
                                                                    capsys, monkeypatch):
    monkeypatch.setattr(ImportedCampaign, "_check", _raising(failure))   # after staging
    (tmp_path / "there").mkdir()
    before = _entries(tmp_path)
    for out in (tmp_path / "new" / "a" / "b" / "campaign",
                tmp_path / "there" / "a" / "campaign"):
        _one_line(capsys, main(["import", str(lab / "map.toml"), "-o", str(out)]))
        assert _entries(tmp_path) == before


def test_analyze_of_a_mapping_whose_import_fails_leaves_no_results_folder(
        lab, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(ImportedCampaign, "_check", _raising(InputError("refused")))
    before = _entries(tmp_path)
    _one_line(capsys, main(["analyze", str(lab / "map.toml"), "-o",
                            str(tmp_path / "new" / "results"), "--no-plots"]))
    assert _entries(tmp_path) == before


# ------------------------------------------------------------------ the output folder's mode
@posix
@pytest.mark.parametrize("mode", [0o750, 0o770, 0o2770, 0o700])
def test_an_existing_empty_output_folder_keeps_its_mode(mode, lab, tmp_path, capsys):
    out = tmp_path / "campaign"
    out.mkdir()
    os.chmod(out, mode)
    assert main(["import", str(lab / "map.toml"), "-o", str(out)]) == 0
    assert stat.S_IMODE(out.stat().st_mode) == mode
    assert (out / "campaign.json").is_file()


@posix
@pytest.mark.parametrize("mask, mode", [(0o022, 0o755), (0o027, 0o750), (0o002, 0o775)])
def test_a_new_output_folder_gets_the_mode_the_umask_gives(mask, mode, lab, tmp_path, capsys):
    old = os.umask(mask)
    try:
        code = main(["import", str(lab / "map.toml"), "-o", str(tmp_path / "campaign")])
    finally:
        os.umask(old)
    assert code == 0
    assert stat.S_IMODE((tmp_path / "campaign").stat().st_mode) == mode


@posix
def test_a_new_output_folder_keeps_the_group_bit_its_parent_passes_down(lab, tmp_path, capsys):
    shared = tmp_path / "shared"
    shared.mkdir()
    os.chmod(shared, 0o2775)
    if not shared.stat().st_mode & stat.S_ISGID:
        pytest.skip("this file system does not keep the set-group-ID bit")
    plain = shared / "plain"
    plain.mkdir()                                   # what mkdir gives there
    assert main(["import", str(lab / "map.toml"), "-o", str(shared / "campaign")]) == 0
    assert (shared / "campaign").stat().st_mode & stat.S_ISGID == \
        plain.stat().st_mode & stat.S_ISGID


def test_a_folder_made_only_to_pass_through_is_not_left(lab, tmp_path, capsys):
    assert main(["import", str(lab / "map.toml"), "-o", str(tmp_path / "new/../c")]) == 0
    assert (tmp_path / "c" / "campaign.json").is_file() and not (tmp_path / "new").exists()


@posix
@pytest.mark.parametrize("target", ["empty", "nowhere"])
def test_an_output_that_is_a_link_is_refused_and_kept(target, lab, tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    (tmp_path / "linked").symlink_to(tmp_path / target)
    before = _entries(tmp_path)
    line = _one_line(capsys, main(["import", str(lab / "map.toml"), "-o",
                                   str(tmp_path / "linked")]))
    assert line == (f"dpdfit: error: {tmp_path / 'linked'}: is a symbolic link: give the folder "
                    "itself (a new folder is written in its place)")
    assert _entries(tmp_path) == before and (tmp_path / "linked").is_symlink()
