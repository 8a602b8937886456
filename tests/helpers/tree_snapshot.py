"""A folder tree recorded so that a test can tell what a command changed in it.

:func:`snapshot` records every entry under a folder without following a link or opening
anything but a regular file (a FIFO or a device in the tree must not hang the record):
a regular file's mode, size, modification time and SHA-256 (of its first MiB when it is
a sparse file of gigabytes), a folder's mode, a link's target, the type and device
number of anything else.  :func:`differences` says what appeared, vanished or changed
between two records.
"""

from __future__ import annotations

import hashlib
import os
import stat
from pathlib import Path

__all__ = ["differences", "snapshot"]

#: a regular file larger than this is hashed on its first MiB (a sparse file of GiB)
_HASHED_WHOLE = 1 << 26


def _digest(path: Path, size: int) -> str:
    with open(path, "rb") as fh:
        return hashlib.sha256(fh.read(1 << 20 if size > _HASHED_WHOLE else size)).hexdigest()


def _entry(path: Path):
    st = os.lstat(path)
    if stat.S_ISLNK(st.st_mode):
        return ("link", os.readlink(path))
    if stat.S_ISREG(st.st_mode):
        return ("file", st.st_mode, st.st_size, st.st_mtime_ns, _digest(path, st.st_size))
    if stat.S_ISDIR(st.st_mode):
        return ("folder", st.st_mode)
    return ("other", st.st_mode, st.st_rdev)


def snapshot(root: Path) -> dict:
    """Every entry under ``root`` (``root`` itself as ``"."``), by path relative to it
    (module doc)."""
    root = Path(root)
    out = {".": _entry(root)}
    for folder, dirs, files in os.walk(root, followlinks=False):
        for name in dirs + files:
            p = Path(folder, name)
            out[p.relative_to(root).as_posix()] = _entry(p)
    return out


def differences(before: dict, after: dict) -> dict:
    """``{"appeared": [...], "vanished": [...], "changed": [...]}``: the paths (sorted)
    that are new in ``after``, gone from it, or recorded otherwise."""
    return {"appeared": sorted(set(after) - set(before)),
            "vanished": sorted(set(before) - set(after)),
            "changed": sorted(p for p in set(before) & set(after) if before[p] != after[p])}
