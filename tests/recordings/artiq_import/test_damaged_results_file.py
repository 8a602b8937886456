"""A results file damaged on its way (one byte flipped) is imported or refused in one line,
never an internal error.

A flip in the file's structure -- the signature of a heap, a B-tree or a symbol-table
node, a byte of a dataset's name -- makes HDF5 (or h5py, for a name that is no longer
UTF-8, which it reports as a ``SystemError`` about its lock) fail where dpdfit lists or
reads the file: each such case is refused, exit 2, one line naming the file, nothing
written, the lab's folder unchanged; it runs in a child process, so that a loop in the
HDF5 library over a damaged file fails the test instead of hanging it.  A flip at a
seeded random offset may land in the values (imported, or refused as implausible): the
import then ends with exit 0 or that one line, never more.
"""

from __future__ import annotations

import random
from pathlib import Path

import pytest

pytest.importorskip("h5py")

from dpdfit.cli.main import INTERNAL_ERROR, main  # noqa: E402
from tests.helpers.small_artiq_lab import SMALL_MAPPING, write_small_lab  # noqa: E402
from tests.helpers.untrusted_campaign import (assert_refused_in_subprocess,  # noqa: E402
                                              tree_state)

#: the seed of the random offsets (any fixed value: the cases are the same on every run)
SEED = 20251009


def _lab(tmp_path: Path) -> tuple[Path, Path]:
    """The small lab (two results files and the mapping); returns (mapping, parity file)."""
    lab = tmp_path / "lab"
    _, parity = write_small_lab(lab)
    (lab / "map.toml").write_text(SMALL_MAPPING)
    return lab / "map.toml", parity


def _flipped(path: Path, offset: int) -> None:
    data = bytearray(path.read_bytes())
    data[offset] ^= 0xFF
    path.write_bytes(bytes(data))


def _offset_of(path: Path, signature: bytes, nth: int = 0) -> int:
    """Where the ``nth`` occurrence of ``signature`` starts in the file."""
    data, start = path.read_bytes(), -1
    for _ in range(nth + 1):
        start = data.index(signature, start + 1)
    return start


@pytest.mark.parametrize("signature, nth, needles", [
    # the local heap of the root group's names, and of datasets/
    (b"HEAP", 0, ["cannot be listed", "bad local heap signature"]),
    (b"HEAP", 1, ["cannot be listed", "bad local heap signature"]),
    # the B-tree of a group's members
    (b"TREE", 1, ["cannot be listed", "B-tree signature"]),
    # a symbol-table node of datasets/
    (b"SNOD", 1, ["cannot be listed", "symbol table node signature"]),
    # the global heap holding the variable-length text (the run's expid)
    (b"GCOL", 0, ["dataset 'expid' cannot be read", "global heap"]),
    # a byte of a dataset's name (h5py: "SystemError: FastRLock" before)
    (b"points.channel_n_even", 0, ["cannot be listed", "a name that is not UTF-8 text"]),
])
def test_a_flip_in_the_structure_is_refused_in_one_line(tmp_path, signature, nth, needles):
    mapping, parity = _lab(tmp_path)
    _flipped(parity, _offset_of(parity, signature, nth))
    line, _ = assert_refused_in_subprocess(["import", mapping, "-o", tmp_path / "out"],
                                           tmp_path, tmp_path / "out",
                                           [parity.name, *needles])
    assert INTERNAL_ERROR not in line and "0x" not in line


def test_a_flip_anywhere_is_imported_or_refused_in_one_line(tmp_path, capsys):
    """Twelve offsets drawn with a fixed seed from the whole file."""
    mapping, parity = _lab(tmp_path)
    clean = parity.read_bytes()
    rng = random.Random(SEED)
    codes = []
    for k in range(12):
        offset = rng.randrange(len(clean))
        parity.write_bytes(clean)
        _flipped(parity, offset)
        before = tree_state(tmp_path)
        out = tmp_path / f"out{k}"
        capsys.readouterr()
        code = main(["import", str(mapping), "-o", str(out)])
        err = capsys.readouterr().err.strip()
        codes.append(code)
        assert code in (0, 2), (offset, code, err)
        if code == 2:
            lines = err.splitlines()
            assert len(lines) == 1 and lines[0].startswith("dpdfit: error:"), (offset, err)
            assert INTERNAL_ERROR not in err and "Traceback" not in err, (offset, err)
            assert parity.name in lines[0], (offset, err)
            assert not out.exists() and tree_state(tmp_path) == before, offset
    assert 2 in codes                   # the seed draws offsets in the structure too
