"""The results files a mapping's ``files`` glob names, found without glob's hazards.

:func:`glob_files` matches a glob as :func:`glob.glob` with ``recursive=True`` does:
``*``, ``?`` and ``[...]`` match within one name (a name starting with ``.`` only
where that part of the glob starts with ``.``), a part ``**`` matches any number of
folders (hidden ones are not entered), and the files come sorted by path.  On a tree
without symbolic links the files are the same.  A results tree copied from another
lab may hold links, so unlike glob:

- a folder is entered at most once at each part of the glob: a link back to a folder
  already visited (a loop) or a second name of one is not followed again, so the walk
  ends (glob walked a loop until the paths grew too long, with its memory growing);
- a file reached under two names is listed once, under the first name in sorted order;
- what a wildcard reaches stays inside the folder the glob names before its first
  wildcard (the mapping's folder for ``*.h5``): a link or a ``..`` leading out of
  it is refused, so a link in someone else's tree cannot make the import read files
  the mapping does not name;
- at most ``limit`` distinct files are found, across all the globs of one source.

:func:`source_files` gathers the globs of one source of the mapping: each file once,
also when an earlier source reached it under another name.

The part of a glob before its first wildcard is the mapping's own choice and is
taken as written: it may be absolute, go up with ``..``, or pass a link (to the
lab's file server, say).  The mapping's folder is used as it is, never as a glob,
so a folder named ``run[1]`` needs no escaping.
"""

from __future__ import annotations

import fnmatch
import os
import re
from pathlib import Path, PurePath

from dpdfit.errors import InputError

__all__ = ["source_files", "glob_files"]

_MAGIC = re.compile(r"[*?\[]")


def source_files(patterns, folder, named: dict, limit: int, where: str,
                 mapping_file: str) -> list[str]:
    """The results files one source's globs match, each once, in the order of its globs
    (each sorted).  A glob that matches no file is an :class:`InputError`, as are the
    refusals of :func:`glob_files`.

    ``named`` maps each file an earlier source took (``(st_dev, st_ino)``) to the path
    it was read under: a file two sources reach under different names is read once,
    under one name; this source's files are added to it.
    """
    found, out = {}, {}
    for pattern in patterns:
        hits = glob_files(pattern, folder, found, limit, where, mapping_file)
        if not hits:
            raise InputError(f"{where}: no file matches '{pattern}'", file=mapping_file)
        out.update(dict.fromkeys(hits))
    first = {path: named.setdefault(ident, path) for ident, path in found.items()}
    return list(dict.fromkeys(first[p] for p in out))


def glob_files(pattern: str, folder, found: dict, limit: int, where: str,
               mapping_file: str) -> list[str]:
    """The files glob ``pattern`` (relative to ``folder`` unless absolute) matches (module doc).

    ``found`` maps each file this source already takes (``(st_dev, st_ino)``) to its
    path; the new ones are added to it.  More than ``limit`` files in all, or a
    wildcard leading out of the glob's folder, is an :class:`InputError` that starts
    with ``where`` (the mapping key and its line) and names ``mapping_file``; the walk
    stops there.  Returns the paths this pattern matched, sorted, each file once (a
    file already in ``found`` is given under the name it has there).
    """
    walk = _Walk(pattern, Path(folder), found, limit, where, mapping_file)
    hits = sorted(walk.files())
    for path, ident in hits:
        found.setdefault(ident, path)
    return list(dict.fromkeys(found[ident] for _, ident in hits))


class _Walk:
    """One glob's walk: the literal folder it starts in, then one part at a time.

    Each part turns the folders matched so far (``level``) into those matched by it
    (``following``), or, for the last part, into files (``hits``)."""

    def __init__(self, pattern: str, folder: Path, found: dict, limit: int, where: str,
                 mapping_file: str):
        self.pattern, self.folder, self.found, self.limit = pattern, folder, found, limit
        self.where, self.mapping_file = where, mapping_file
        # a glob ending in a separator names folders, which are no results files
        self.folders_only = pattern.endswith(("/", os.sep))
        parts = PurePath(pattern).parts
        first = next((i for i, p in enumerate(parts) if _MAGIC.search(p)), len(parts))
        self.head = _text(Path(folder, *parts[:first]))
        self.parts = parts[first:]
        self.base = ""
        self.seen: set = set()
        self.hits: list = []
        self.new: set = set()

    def files(self) -> list[tuple[str, tuple]]:
        """(path, identity) of every file matched, in no particular order."""
        if self.folders_only:
            return []
        if not self.parts:                         # no wildcard: the file named, if it is one
            if os.path.isfile(self.head):
                self._hit(self.head, self.head)
            return self.hits
        if not os.path.isdir(self.head or os.curdir):
            return []
        self.base = os.path.realpath(self.head or os.curdir)
        level = [self.head]
        for i, part in enumerate(self.parts):
            last = i == len(self.parts) - 1
            following: list = []
            for d in level:
                if part == "**":
                    self._tree(d, i, last, following)
                elif _MAGIC.search(part):
                    for name, path, entry in _entries(d):
                        if (not _hidden(name) or _hidden(part)) and fnmatch.fnmatch(name, part):
                            self._take(path, entry, i, last, following)
                elif os.path.lexists(path := os.path.join(d, part)):
                    self._take(path, None, i, last, following, dotdot=part == os.pardir)
            level = following
        return self.hits

    def _tree(self, d: str, i: int, last: bool, following: list) -> None:
        """``**``: folder ``d`` and every folder below it, each entered once (and, as the
        glob's last part, every file in them).  A stack, not recursion: a tree may be
        deeper than Python's recursion limit."""
        if not self._enter(d, ("tree", i)):
            return
        stack = [d]
        while stack:
            folder = stack.pop()
            if not last:
                following.append(folder)
            below = []
            for name, path, entry in _entries(folder):
                if _hidden(name):
                    continue
                if _is_dir(entry):
                    self._check_inside(path, entry.is_symlink())
                    if self._enter(path, ("tree", i)):
                        below.append(path)
                elif last and _is_file(entry):
                    self._check_inside(path, entry.is_symlink())
                    self._hit(path, entry)
            stack.extend(reversed(below))          # depth first, in sorted order

    def _take(self, path: str, entry, i: int, last: bool, following: list,
              dotdot: bool = False) -> None:
        """A path part ``i`` matched: a file kept (the last part), or a folder to go on in."""
        item = path if entry is None else entry
        link = os.path.islink(path) if entry is None else entry.is_symlink()
        if last:
            if _is_file(item):
                self._check_inside(path, link or dotdot)
                self._hit(path, item)
        elif _is_dir(item):
            self._check_inside(path, link or dotdot)
            if self._enter(path, ("after", i)):
                following.append(path)

    def _hit(self, path: str, item) -> None:
        """Keep a file; stop when the source would read more than the limit."""
        try:
            ident = _identity(item)
        except OSError:                            # gone since it was listed
            return
        self.hits.append((path, ident))
        if ident not in self.found:
            self.new.add(ident)
            if len(self.found) + len(self.new) > self.limit:
                raise InputError(f"{self.where}: the source matches more than "
                                 f"{self.limit:,} files, the most one source reads (at "
                                 f"'{self.pattern}'): narrow its globs or split it into "
                                 "several sources", file=self.mapping_file)

    def _enter(self, path: str, position: tuple) -> bool:
        """True the first time folder ``path`` (its device and inode) is at ``position``."""
        try:
            key = (*_identity(path), *position)
        except OSError:
            return False
        if key in self.seen:
            return False
        self.seen.add(key)
        return True

    def _check_inside(self, path: str, leaves: bool) -> None:
        """Refuse ``path`` if it is a link or ``..`` (``leaves``) resolving outside the base."""
        if not leaves:
            return
        real = os.path.realpath(path)
        if os.path.commonpath([real, self.base]) == self.base:
            return
        raise InputError(f"{self.where}: '{self.pattern}' reaches '{_shown(path, self.folder)}', "
                         f"which leads outside '{_shown(self.head, self.folder)}' (to "
                         f"'{real}'): refused; a wildcard reads only inside the folder named "
                         "before it", file=self.mapping_file)


def _text(path: Path) -> str:
    """A path as glob joins it: the current folder is the empty prefix."""
    s = str(path)
    return "" if s == os.curdir else s


def _shown(path: str, folder: Path) -> str:
    """``path`` as the glob wrote it, relative to the mapping's folder (``..`` kept)."""
    prefix = _text(folder)
    if not prefix or path.startswith(prefix + os.sep):
        return Path(path[len(prefix) + 1:] if prefix else path).as_posix() or "."
    try:
        return Path(os.path.relpath(path or os.curdir, folder)).as_posix()
    except ValueError:                                  # another drive (Windows)
        return Path(path).as_posix()


def _entries(folder: str) -> list:
    """``(name, path, entry)`` of each entry of ``folder``, sorted by name; none if it
    cannot be listed (as glob)."""
    try:
        with os.scandir(folder or os.curdir) as it:
            entries = list(it)
    except OSError:
        return []
    return sorted((e.name, os.path.join(folder, e.name), e) for e in entries)


def _hidden(name: str) -> bool:
    return name.startswith(".")


def _is_dir(item) -> bool:
    try:
        return item.is_dir() if not isinstance(item, str) else os.path.isdir(item)
    except OSError:
        return False


def _is_file(item) -> bool:
    try:
        return item.is_file() if not isinstance(item, str) else os.path.isfile(item)
    except OSError:
        return False


def _identity(item) -> tuple:
    """``(st_dev, st_ino)`` of a path or directory entry, links followed."""
    st = os.stat(item) if isinstance(item, str) else item.stat()
    return st.st_dev, st.st_ino
