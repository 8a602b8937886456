"""The mapping's ``files`` globs: glob's matches on an ordinary tree, and on a tree with
symbolic links (as a results folder copied from another lab may hold) a walk that ends,
reads each file once, stays inside the folder the glob names, and stops at the limit."""

from __future__ import annotations

import glob
import json
import os
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dpdfit.errors import InputError
from dpdfit.recordings.file_globs import glob_files

pytest.importorskip("h5py")

from dpdfit.cli.main import main  # noqa: E402
from tests.helpers.small_artiq_lab import SMALL_MAPPING, write_small_lab  # noqa: E402

links = pytest.mark.skipif(sys.platform == "win32", reason="symbolic links need privileges")


def _glob(pattern, folder, limit=1000):
    return glob_files(pattern, Path(folder), {}, limit, "mapping key 'k.files' (line 2)",
                      "map.toml")


# ------------------------------------------------------------------ glob's own matches
NAMES = ["a", "b", "ab", ".h", "x.h5", "y.h5", ".z.h5", "a.h5", "[a]"]
PARTS = ["*", "**", "?", "a", "*.h5", ".*", "[ab]", "x.h5", "a*", "*b", "[[]a]", "**"]


def _trees(depth):
    leaf = st.just(None)                           # a file
    if depth == 0:
        return st.dictionaries(st.sampled_from(NAMES), leaf, max_size=4)
    return st.dictionaries(st.sampled_from(NAMES), st.one_of(leaf, _trees(depth - 1)),
                           max_size=4)


def _write(folder: Path, tree: dict) -> None:
    for name, sub in tree.items():
        if sub is None:
            (folder / name).write_text(name)
        else:
            (folder / name).mkdir()
            _write(folder / name, sub)


@settings(max_examples=150, deadline=None, derandomize=True)
@given(tree=_trees(3), parts=st.lists(st.sampled_from(PARTS), min_size=1, max_size=4),
       under=st.sampled_from(["", "a"]))
def test_an_ordinary_tree_gives_what_glob_gives(tmp_path_factory, tree, parts, under):
    folder = tmp_path_factory.mktemp("tree")
    _write(folder, tree)
    pattern = "/".join(([under] if under else []) + parts)
    expected = list(dict.fromkeys(sorted(
        p for p in glob.glob(str(folder / pattern), recursive=True) if os.path.isfile(p))))
    assert _glob(pattern, folder) == expected


def test_a_literal_and_an_absolute_pattern_and_a_folder_named_like_a_glob(tmp_path):
    folder = tmp_path / "run[1]"                   # glob would read "[1]" as a wildcard
    (folder / "r").mkdir(parents=True)
    (folder / "r" / "x.h5").write_text("x")
    assert _glob("r/*.h5", folder) == [str(folder / "r" / "x.h5")]
    assert _glob("r/x.h5", folder) == [str(folder / "r" / "x.h5")]
    plain = tmp_path / "plain"
    folder.rename(plain)
    assert _glob(str(plain / "r") + "/*.h5", tmp_path / "elsewhere") == \
        [str(plain / "r" / "x.h5")]                 # an absolute glob is not relative
    plain.rename(folder)
    assert _glob("r/", folder) == [] and _glob("r/*/", folder) == []


# ------------------------------------------------------------------ links
@links
def test_a_link_loop_ends_and_each_file_is_found_once(tmp_path):
    (tmp_path / "results" / "a" / "b").mkdir(parents=True)
    (tmp_path / "results" / "a" / "b" / "x.h5").write_text("x")
    os.symlink("..", tmp_path / "results" / "a" / "b" / "up")           # b/up -> a
    os.symlink("../..", tmp_path / "results" / "a" / "b" / "top")       # b/top -> results
    (tmp_path / "results" / "c").symlink_to(tmp_path / "results" / "a")  # a second name
    assert _glob("results/**/*.h5", tmp_path) == [str(tmp_path / "results/a/b/x.h5")]
    assert _glob("results/*/*/*.h5", tmp_path) == [str(tmp_path / "results/a/b/x.h5")]


def test_a_tree_deeper_than_the_recursion_limit_is_walked(tmp_path):
    deep = Path(tmp_path / "results", *["d"] * 400)
    deep.mkdir(parents=True)
    (deep / "x.h5").write_text("x")
    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(250)
    try:
        found = _glob("results/**/*.h5", tmp_path)
    finally:
        sys.setrecursionlimit(limit)
    assert found == [str(deep / "x.h5")]


@links
@pytest.mark.parametrize("link, target", [("results/a/out", "../../private"),
                                          ("results/out.h5", "../private/secret.h5")])
def test_a_wildcard_never_leads_outside_the_folder_named_before_it(tmp_path, link, target):
    (tmp_path / "results" / "a").mkdir(parents=True)
    (tmp_path / "results" / "a" / "x.h5").write_text("x")
    (tmp_path / "private").mkdir()
    (tmp_path / "private" / "secret.h5").write_text("s")
    os.symlink(target, tmp_path / link)
    with pytest.raises(InputError) as refused:
        _glob("results/**/*.h5", tmp_path)
    msg = str(refused.value)
    assert "\n" not in msg and msg.startswith("map.toml: mapping key 'k.files' (line 2): ")
    assert f"'results/**/*.h5' reaches '{link}'" in msg
    assert "outside 'results'" in msg and str(tmp_path / "private") in msg
    with pytest.raises(InputError, match=r"reaches 'results/a/\.\./\.\.'"):
        _glob("results/*/../../private/*.h5", tmp_path)
    assert _glob("private/*.h5", tmp_path) == [str(tmp_path / "private" / "secret.h5")]


@links
def test_the_folder_named_before_the_wildcard_may_be_a_link_anywhere(tmp_path):
    (tmp_path / "server" / "2025").mkdir(parents=True)
    (tmp_path / "server" / "2025" / "x.h5").write_text("x")
    (tmp_path / "lab").mkdir()
    (tmp_path / "lab" / "results").symlink_to(tmp_path / "server")  # the lab's file server
    assert _glob("results/**/*.h5", tmp_path / "lab") == \
        [str(tmp_path / "lab" / "results" / "2025" / "x.h5")]


def test_more_files_than_the_limit_are_refused_naming_the_source_and_glob(tmp_path):
    for i in range(5):
        (tmp_path / f"{i}.h5").write_text(str(i))
    found = {}
    assert len(glob_files("[01]*.h5", tmp_path, found, 3, "K", "map.toml")) == 2
    with pytest.raises(InputError) as refused:
        glob_files("*.h5", tmp_path, found, 3, "mapping key 'parity[1].files' (line 9)",
                   "map.toml")
    assert str(refused.value) == (
        "map.toml: mapping key 'parity[1].files' (line 9): the source matches more than 3 "
        "files, the most one source reads (at '*.h5'): narrow its globs or split it into "
        "several sources")


# ------------------------------------------------------------------ through dpdfit import
@links
def test_import_reads_a_file_reached_twice_once(tmp_path, capsys):
    lab = tmp_path / "lab"
    write_small_lab(lab)
    (lab / "map.toml").write_text(SMALL_MAPPING.replace(
        '"results/**/*-ParityScan.h5"', '["results/**/*-ParityScan.h5", "again/*/*/*-ParityScan.h5"]'))
    (lab / "again").symlink_to(lab / "results")
    os.symlink("..", next((lab / "results").glob("*/*")) / "loop")
    assert main(["import", str(lab / "map.toml"), "-o", str(tmp_path / "c")]) == 0, \
        capsys.readouterr().err
    sources = json.loads((tmp_path / "c" / "campaign.json").read_text())["imported"]["sources"]
    assert sorted(s["file"] for s in sources) == sorted(
        p.relative_to(lab).as_posix() for p in (lab / "results").glob("*/*/*.h5"))


def test_import_refuses_a_source_over_the_limit_in_one_line(tmp_path, capsys, monkeypatch):
    import dpdfit.recordings.campaign_import as ci
    monkeypatch.setattr(ci, "MAX_FILES_PER_SOURCE", 0)
    lab = tmp_path / "lab"
    write_small_lab(lab)
    (lab / "map.toml").write_text(SMALL_MAPPING)
    assert main(["import", str(lab / "map.toml"), "-o", str(tmp_path / "c")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(
        f"dpdfit: error: {lab / 'map.toml'}: mapping key 'calibration_amplitude[1].files' "
        "(line 5): the source matches more than 0 files"), err
    assert "(at 'results/**/*-AmplitudeCalibration.h5')" in err
    assert not (tmp_path / "c").exists()
