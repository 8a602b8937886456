"""``dpdfit import`` on generated inputs: imported, or refused in one line; never more.

For any mapping, any results files, any tree of folders and links around them and
any output path, ``main(["import", MAP, "-o", OUT, ...])`` exits with 0 or 2.  With 2,
stderr is exactly one line ``dpdfit: error: ...``, and not the command line's last line
of defence (an internal error, memory or recursion exhausted: an input no check gave
a message of its own, a traceback in disguise), and nothing was written: every file,
folder and link under the test's folder is as it was, modes included.  With 0, only
OUT (and the folders made for it) is new, an output folder that existed keeps its
mode, and ``campaign.json`` lists every results file the rows came from, each once,
with its SHA-256.  The inputs are never changed.

The mappings are edits of a small lab's mapping (:mod:`tests.helpers.mapping_strategies`),
the results files edits of its two files (:mod:`tests.helpers.results_file_strategies`),
the trees links and copies around them with globs and output paths of every kind.
Each test runs a fixed, derandomized number of examples; ``-m slow`` runs more.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import logging
import os
import shutil
import sys
import tempfile
import warnings
from pathlib import Path

import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest.importorskip("h5py")

from dpdfit.cli.main import INTERNAL_ERROR, OUT_OF_MEMORY, TOO_DEEP, main  # noqa: E402
from tests.helpers.mapping_strategies import mapping_texts  # noqa: E402
from tests.helpers.results_file_strategies import (apply_file_edits, file_edits,  # noqa: E402
                                                   write_outside_file)
from tests.helpers.small_artiq_lab import SMALL_MAPPING, write_small_lab  # noqa: E402

FEW = settings(max_examples=30, deadline=None, derandomize=True, database=None,
               suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
MANY = settings(FEW, max_examples=150)
LAST_LINE = tuple(f"dpdfit: error: {s}" for s in (INTERNAL_ERROR, OUT_OF_MEMORY, TOO_DEEP))
LINKS = pytest.mark.skipif(sys.platform == "win32", reason="symbolic links need privileges")
OPTIONS = st.lists(st.sampled_from(["--complete-only", "--skip-bad-files", "--no-progress"]),
                   unique=True, max_size=2)


@pytest.fixture(scope="module")
def pristine(tmp_path_factory):
    """The small lab (mapping and two results files) and a results file outside it."""
    root = tmp_path_factory.mktemp("pristine")
    files = write_small_lab(root / "lab")
    (root / "lab" / "map.toml").write_text(SMALL_MAPPING)
    write_outside_file(root / "elsewhere.h5")
    return root, {"cal": files[0].relative_to(root), "par": files[1].relative_to(root)}


# ----------------------------------------------------------------------------- the contract
def _snapshot(root: Path) -> dict:
    """Every path under ``root``: a folder's mode, a file's mode and digest, a link's target."""
    out = {}
    for folder, dirs, files in os.walk(root):
        for name in dirs + files:
            p = Path(folder, name)
            rel, st_ = p.relative_to(root).as_posix(), os.lstat(p)
            if p.is_symlink():
                out[rel] = ("link", os.readlink(p))
            elif p.is_dir():
                out[rel] = ("dir", st_.st_mode)
            else:
                out[rel] = ("file", st_.st_mode, hashlib.sha256(p.read_bytes()).hexdigest())
    return out


class _Traceback(logging.Handler):
    """Keeps the traceback the last line of defence logs at DEBUG level."""

    def __init__(self):
        super().__init__(logging.DEBUG)
        self.text = ""

    def emit(self, record):
        if record.exc_info:
            self.text = logging.Formatter().formatException(record.exc_info)


def run_import(root: Path, mapping: str, out: str, options=()) -> str:
    """``dpdfit import mapping -o out`` in ``root`` (paths relative to it); assert the
    contract of the module doc.  Returns the error line, or "" for an import."""
    before = _snapshot(root)
    argv = ["import", str(root / mapping), "-o", str(root / out) if out else "", *options]
    stdout, stderr, tb = io.StringIO(), io.StringIO(), _Traceback()
    logger = logging.getLogger("dpdfit.cli.main")
    logger.addHandler(tb)
    level = logger.level
    logger.setLevel(logging.DEBUG)
    try:
        with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr), \
                warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")          # as a user sees them: on stderr
            code = main(argv)
    finally:
        logger.removeHandler(tb)
        logger.setLevel(level)
    err = stderr.getvalue() + "".join(
        warnings.formatwarning(w.message, w.category, w.filename, w.lineno) for w in caught)
    after = _snapshot(root)
    where = f"{err.strip()}\n{tb.text[-3000:]}"
    assert code in (0, 2), f"exit status {code}: {where}"
    assert "Traceback" not in err, where
    if code == 2:
        lines = err.splitlines()
        assert len(lines) == 1 and lines[0].startswith("dpdfit: error: "), where
        assert not lines[0].startswith(LAST_LINE), where
        # the staging folder is gone by the time the user reads the line
        assert not Path(out).name or f"{os.sep}.{Path(out).name}." not in lines[0], where
        assert after == before, "a refused import changed the folder: " + \
            f"{sorted(set(after.items()) ^ set(before.items()))[:6]} ({lines[0]})"
        return lines[0]
    _check_written(root, out, before, after)
    return ""


def _check_written(root: Path, out: str, before: dict, after: dict) -> None:
    target = Path(os.path.normpath(root / out)).relative_to(root).as_posix()
    ancestors = {p.as_posix() for p in Path(target).parents}
    new = {p: v for p, v in after.items() if p not in before and not (
        p == target or p.startswith(target + "/") or p in ancestors)}
    assert not new, f"written besides {target}: {sorted(new)[:6]}"
    assert {p: v for p, v in after.items() if p in before} == before, \
        "an existing path changed (an output folder's mode, an input)"
    meta = json.loads((root / target / "campaign.json").read_text())
    sources = meta["imported"]["sources"]
    files = [s["file"] for s in sources]
    assert len(files) == len(set(files)), f"a results file listed twice: {files}"
    mapping_folder = (root / "lab").resolve()
    for s in sources:
        read = (mapping_folder / s["file"]).resolve()
        assert hashlib.sha256(read.read_bytes()).hexdigest() == s["sha256"], s["file"]
    for csv in (root / target).glob("*.csv"):
        rows = set(pd.read_csv(csv)["source_file"].astype(str))
        assert rows <= set(files), f"{csv.name}: rows from files campaign.json omits"


def _fresh(pristine, d: Path) -> dict:
    root, files = pristine
    shutil.copytree(root, d, dirs_exist_ok=True, symlinks=True)
    return {k: d / v for k, v in files.items()}


# ----------------------------------------------------------------------------- the tests
@FEW
@given(text=mapping_texts(), options=OPTIONS)
def test_generated_mappings_are_imported_or_refused_in_one_line(pristine, text, options):
    with tempfile.TemporaryDirectory() as d:
        _fresh(pristine, Path(d))
        (Path(d) / "lab" / "map.toml").write_text(text, encoding="utf-8")
        run_import(Path(d), "lab/map.toml", "new/campaign", options)


@FEW
@given(edits=file_edits(), options=OPTIONS)
def test_generated_results_files_are_imported_or_refused_in_one_line(pristine, edits,
                                                                     options):
    with tempfile.TemporaryDirectory() as d:
        paths = _fresh(pristine, Path(d))
        apply_file_edits(paths, Path(d) / "elsewhere.h5", edits)
        run_import(Path(d), "lab/map.toml", "new/campaign", options)


@pytest.mark.parametrize("key", ["ndscan.rid_1.completed",
                                 "ndscan.rid_1.points.channel_pd_power"])
def test_a_ragged_dataset_of_empty_arrays_is_imported_or_refused_in_one_line(pristine, key):
    """Found by the tests above with random seeds: a per-shot channel with no shot."""
    with tempfile.TemporaryDirectory() as d:
        paths = _fresh(pristine, Path(d))
        apply_file_edits(paths, Path(d) / "elsewhere.h5", [("cal", "array", key,
                                                            ("ragged", (11,), 0))])
        run_import(Path(d), "lab/map.toml", "new/campaign")


@pytest.mark.slow
@MANY
@given(text=mapping_texts(), edits=file_edits(), options=OPTIONS)
def test_generated_mappings_and_results_files_together(pristine, text, edits, options):
    with tempfile.TemporaryDirectory() as d:
        paths = _fresh(pristine, Path(d))
        apply_file_edits(paths, Path(d) / "elsewhere.h5", edits)
        (Path(d) / "lab" / "map.toml").write_text(text, encoding="utf-8")
        run_import(Path(d), "lab/map.toml", "new/campaign", options)


# ----------------------------------------------------------------------------- trees and outputs
#: links and copies around the lab: (path relative to the test's folder, link target or
#: None for a copy of the parity file)
TREE_EDITS = [("lab/results/2025-10-09/09/up", "../.."),          # a loop, inside results
              ("lab/results/2025-10-09/09/top", "../../.."),      # out of results, to lab
              ("lab/results/2025-10-09/away", "../../../outside"),   # out of the lab
              ("lab/results/2025-10-09/gone", "nowhere"),         # dangling
              ("lab/again", "results"),                           # a second name
              ("lab/results/late.h5", "2025-10-09/09/000000002-ParityScan.h5"),
              ("lab/results/2025-10-09/copy-ParityScan.h5", None),    # the same bytes again
              ("outside/2025/000000002-ParityScan.h5", None)]
GLOBS = ["results/**/*-ParityScan.h5", "again/**/*-ParityScan.h5", "**/*-ParityScan.h5",
         "results/*/*/../*/*-ParityScan.h5", "../lab/results/**/*-ParityScan.h5",
         "{lab}/results/**/*-ParityScan.h5", "results/**", "results/[0-9]*/**/*Parity*",
         "results/**/*.h5", "../outside/**/*.h5", "results/*/*/*/*.h5"]
#: output paths (relative to the test's folder) and what is there before
OUTPUTS = [("new/campaign", None), ("campaign", None), ("empty", 0o750), ("empty", 0o2770),
           ("full", "x"), ("file", b"x"), ("lab/map.toml", None), ("lab/results", None),
           ("lab/map.toml/under", None), ("lab/out", None), ("", None),
           ("new/../campaign", None), ("outside/deeper/c", None), ("linked", ("empty", 0o755)),
           ("linked", ("nowhere", None)), ("linked", ("full", "x"))]


@st.composite
def trees(draw):
    """(tree edits, the globs of the parity source, output path and its state, mapping path)."""
    edits = draw(st.lists(st.sampled_from(TREE_EDITS), unique=True, max_size=3))
    globs = draw(st.lists(st.sampled_from(GLOBS), min_size=1, max_size=2))
    mapping = draw(st.sampled_from(["lab/map.toml"] * 6 + ["lab", "lab/none.toml",
                                                           "lab/map[1].toml"]))
    return edits, globs, draw(st.sampled_from(OUTPUTS)), mapping


def _grow(root: Path, edits, globs, output, mapping: str) -> None:
    lab = root / "lab"
    parity = next(lab.glob("results/*/*/*-ParityScan.h5"))
    for path, target in edits:
        p = root / path
        p.parent.mkdir(parents=True, exist_ok=True)
        if target is None:
            shutil.copy(parity, p)
        else:
            (root / "outside").mkdir(exist_ok=True)
            os.symlink(target, p)
    files = json.dumps([g.format(lab=lab.as_posix()) for g in globs])
    text = SMALL_MAPPING.replace('"results/**/*-ParityScan.h5"', files)
    (lab / "map.toml").write_text(text)
    if mapping == "lab/map[1].toml":
        (lab / "map[1].toml").write_text(text)
    out, before = output
    if isinstance(before, tuple):                   # a link to what the tuple makes
        _grow(root, [], globs, before, mapping)
        os.symlink(before[0], root / out)
    elif isinstance(before, int):
        (root / out).mkdir()
        os.chmod(root / out, before)
    elif isinstance(before, str):
        (root / out).mkdir()
        (root / out / before).write_text(before)
    elif isinstance(before, bytes):
        (root / out).write_bytes(before)


def _tree_import(pristine, tree, options) -> None:
    edits, globs, output, mapping = tree
    with tempfile.TemporaryDirectory() as d:
        _fresh(pristine, Path(d))
        _grow(Path(d), edits, globs, output, mapping)
        run_import(Path(d), mapping, output[0], options)


@LINKS
@FEW
@given(tree=trees(), options=OPTIONS)
def test_generated_trees_globs_and_output_paths(pristine, tree, options):
    _tree_import(pristine, tree, options)


@LINKS
@pytest.mark.slow
@MANY
@given(tree=trees(), options=OPTIONS)
def test_generated_trees_globs_and_output_paths_many(pristine, tree, options):
    _tree_import(pristine, tree, options)
