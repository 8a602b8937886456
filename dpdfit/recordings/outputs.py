"""Output helpers at the edge of the package: atomic writes, output tables and file hashes.

Nothing dpdfit writes is ever half-written: every output goes to a temporary
file in the destination directory and is moved into place with
:func:`os.replace` (atomic on POSIX and Windows).  Groups of files are staged
together and only moved once all of them were written, so a failure leaves no
partial output behind.  Inputs are never overwritten: callers pass the input
paths and :func:`refuse_overwriting_inputs` raises if an output would land on
one of them.

Every output table is written as CSV text by :func:`csv_table_text` (or
:func:`write_csv_table`): a text cell that a spreadsheet would run as a formula --
one starting with ``=``, ``+``, ``-``, ``@`` (spaces before them aside), a tab or a
carriage return, and not a number (``-1.5`` is a number;
:mod:`~dpdfit.recordings.formula_cells`) -- is refused, naming the table, column and row
(:func:`refuse_formula_cells`), instead of being written for a lab to open.  Such a
cell can only come from a file from elsewhere (a mapping's ``format``, an extra column
of a campaign table), which is refused on input too; this is the last guard.
"""

from __future__ import annotations

import contextlib
import contextvars
import errno
import hashlib
import json
import os
import shutil
import signal
import stat
import tempfile
import threading
from pathlib import Path
from typing import Iterable, Iterator

from dpdfit.core.jsonable import to_jsonable
from dpdfit.errors import InputError
from dpdfit.recordings.formula_cells import FORMULA_STARTS, first_formula_cell, runs_as_formula

__all__ = ["read_csv_header", "write_csv_with_header", "sha256_file", "file_sha256",
           "remember_sha256", "staged_folder", "folder_made", "refuse_overwriting_inputs",
           "staged_outputs", "Stage", "check_output_folder", "check_output_file",
           "atomic_write_text", "atomic_write_json", "FORMULA_STARTS",
           "refuse_formula_cells", "csv_table_text", "write_csv_table"]


def sha256_file(path: str | os.PathLike) -> str:
    """Hex SHA-256 digest of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


#: digests of file versions already read, ``{(realpath, mtime_ns, size): hex}``
_DIGESTS: dict = {}
_MAX_DIGESTS = 256


def _version(path) -> tuple:
    st = os.stat(path)
    return os.path.realpath(path), st.st_mtime_ns, st.st_size


def remember_sha256(path: str | os.PathLike, data: bytes) -> None:
    """Note the digest of ``data``, the bytes just read from ``path``: a reader that has
    the bytes in hand spares :func:`file_sha256` opening the file again."""
    if len(_DIGESTS) >= _MAX_DIGESTS:
        _DIGESTS.pop(next(iter(_DIGESTS)))
    _DIGESTS[_version(path)] = hashlib.sha256(data).hexdigest()


def file_sha256(path: str | os.PathLike) -> str:
    """SHA-256 of a file, computed once per version (path, mtime, size) of the file.

    The runs of one calibration file share its digest (hashing the whole file once
    per run made fitting every run quadratic in the number of runs), and a file
    whose reader noted its digest (:func:`remember_sha256`) is not opened again.
    """
    key = _version(path)
    if key not in _DIGESTS:
        if len(_DIGESTS) >= _MAX_DIGESTS:
            _DIGESTS.pop(next(iter(_DIGESTS)))
        _DIGESTS[key] = sha256_file(path)
    return _DIGESTS[key]


def refuse_overwriting_inputs(outputs: Iterable[str | os.PathLike],
                              inputs: Iterable[str | os.PathLike]) -> None:
    """Raise :class:`InputError` if any output path is one of the inputs (or is a
    symbolic link loop)."""
    ins = {_resolved(p) for p in inputs if p is not None}
    for out in outputs:
        if out is not None and _resolved(out) in ins:
            raise InputError("refusing to overwrite an input file; choose another output path",
                             file=str(out))


def check_output_folder(path: str | os.PathLike, what: str = "output folder") -> None:
    """Raise :class:`InputError` now, before any work, if ``path`` cannot become a folder of outputs.

    It must be a folder or not exist yet, and its nearest existing parent must be
    a folder we may write into.
    """
    p = Path(path)
    _resolved(p, what)
    if p.exists() and not p.is_dir():
        raise InputError(f"{what} is an existing file, not a folder", file=str(path))
    _check_writable_parent(p if p.exists() else p.parent, path, what)


def check_output_file(path: str | os.PathLike, what: str = "output file") -> None:
    """Raise :class:`InputError` now, before any work, if ``path`` cannot be written as a file."""
    p = Path(path)
    _resolved(p, what)
    if p.is_dir():
        raise InputError(f"{what} is an existing folder; give a file name", file=str(path))
    _check_writable_parent(p.parent, path, what)


def _resolved(path, what: str = "path") -> Path:
    """``path`` resolved, or an InputError naming it when it leads through a symbolic
    link loop (``Path.resolve`` raises RuntimeError there, before Python 3.13)."""
    try:
        return Path(path).resolve()
    except RuntimeError:
        raise InputError(f"{what} is a symbolic link loop", file=str(path)) from None
    except OSError as exc:
        why = "is a symbolic link loop" if exc.errno == errno.ELOOP else (
            f"cannot be resolved ({exc.strerror or exc})")
        raise InputError(f"{what} {why}", file=str(path)) from None


def _check_writable_parent(folder: Path, path, what: str) -> None:
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    if not folder.is_dir():
        raise InputError(f"cannot create the {what}: {folder} is a file", file=str(path))
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InputError(f"cannot create the {what}: no permission to write in {folder}",
                         file=str(path))


class Stage:
    """The files of one publication: ``stage(final) -> temp path``; ``stage.remove(path)``.

    Made by :func:`staged_outputs`.  Each staged file is a temporary file in its
    final directory, created with the permissions the umask gives a new file
    (``0o666 & ~umask``, as ``open`` would, not :func:`tempfile.mkstemp`'s 0600).
    ``remove(path)`` schedules an old output for deletion when the others are
    published (a rerun clearing what it owned).
    """

    def __init__(self):
        self.staged: list[tuple[Path, Path]] = []
        self.removals: list[Path] = []
        self.made_dirs: list[Path] = []
        self._mode = _new_file_mode()

    def __call__(self, final: str | os.PathLike) -> Path:
        final = Path(final)
        self._makedirs(final.parent)
        fd, tmp = tempfile.mkstemp(prefix=f".{final.name}.", suffix=".part", dir=final.parent)
        os.close(fd)
        os.chmod(tmp, self._mode)
        self.staged.append((Path(tmp), final))
        return Path(tmp)

    def remove(self, path: str | os.PathLike) -> None:
        """Delete ``path`` (if it exists) when the staged files are published."""
        self.removals.append(Path(path))

    @property
    def finals(self) -> list[Path]:
        """The final paths of the staged files, in the order they were staged."""
        return [final for _, final in self.staged]

    def _makedirs(self, folder: Path) -> None:
        self.made_dirs += _make_folders(folder)

    def discard(self) -> None:
        """Remove every temporary file and every folder made for them (now empty)."""
        for tmp, _ in self.staged:
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
        _remove_empty(self.made_dirs)

    def publish(self) -> None:
        """Move every staged file into place, then delete the scheduled removals.

        Ctrl-C (SIGINT) is held back until all of them are done, so an interrupt
        leaves either the previous outputs or the new ones, never a mixture.
        """
        with _sigint_deferred():
            keep = {final.resolve() for final in self.finals}
            for tmp, final in self.staged:
                os.replace(tmp, final)
            for old in self.removals:
                if old.resolve() not in keep:
                    with contextlib.suppress(FileNotFoundError):
                        old.unlink()


#: The publication in progress, joined by nested :func:`staged_outputs` calls.
_ACTIVE: contextvars.ContextVar[Stage | None] = contextvars.ContextVar("dpdfit_stage",
                                                                      default=None)


@contextlib.contextmanager
def staged_outputs() -> Iterator[Stage]:
    """Stage several output files and publish them together.

    Yields a :class:`Stage` ``stage``: ``stage(final_path) -> temp_path``; write
    each output to the returned temporary path.  On normal exit every staged
    file is moved to its final path (and ``stage.remove``-d files deleted);
    on an exception, Ctrl-C included, all temporaries are removed and no final
    path is touched.  Nested calls join the outermost one, so a command that
    writes a table with one helper and figures with another publishes both
    together, at the end.
    """
    outer = _ACTIVE.get()
    if outer is not None:
        yield outer
        return
    stage = Stage()
    token = _ACTIVE.set(stage)
    try:
        yield stage
    except BaseException:
        stage.discard()
        raise
    finally:
        _ACTIVE.reset(token)
    stage.publish()


def _new_file_mode() -> int:
    """The mode a new file gets under the current umask (``0o666 & ~umask``)."""
    return 0o666 & ~_umask()


@contextlib.contextmanager
def _sigint_deferred():
    """Hold back SIGINT (Ctrl-C) while the block runs; raise it after (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught = []
    previous = signal.getsignal(signal.SIGINT)
    if previous is None:  # a handler not installed from Python: leave it alone
        yield
        return
    signal.signal(signal.SIGINT, lambda *a: caught.append(a))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if caught:
        raise KeyboardInterrupt


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` to ``path`` atomically."""
    with staged_outputs() as stage:
        stage(path).write_text(text)


@contextlib.contextmanager
def staged_folder(out: str | os.PathLike) -> Iterator[Path]:
    """A new folder ``out`` that appears whole or not at all.

    Yields a temporary folder beside ``out`` to write into; when the block ends
    without error it replaces ``out``, which must not exist or be empty, and has its
    mode: the mode (and group, where allowed) of the empty folder it replaces, else
    what the umask gives a new folder (``mkdtemp`` makes it private).  On any error
    or interrupt the temporary folder is removed, ``out`` is untouched, and the
    parents of ``out`` made for it are removed again.  A symbolic link ``out`` is
    refused (:class:`InputError`).
    """
    out = Path(out)
    if out.is_symlink():
        # replacing it would cut the link; writing through it would replace its target
        raise InputError("is a symbolic link: give the folder itself (a new folder is "
                         "written in its place)", file=str(out))
    with folder_made(out.parent) as made:
        tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
        try:
            yield tmp
            _mode_of(out, tmp)
            if out.exists():
                out.rmdir()
            os.replace(tmp, out)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
    # a folder made only to be passed through (``new/../out``) is empty: not kept
    _remove_empty(made)


@contextlib.contextmanager
def folder_made(folder: str | os.PathLike) -> Iterator[list[Path]]:
    """Make the folder ``folder`` and its missing parents, if need be; yields the folders
    made, outermost first.

    If the block raises, the folders made here are removed again, deepest first, as
    far as they are empty: a failed command leaves no empty folders behind, and never
    removes a folder that was there before.
    """
    made = _make_folders(Path(folder))
    try:
        yield made
    except BaseException:
        _remove_empty(made)
        raise


def _make_folders(folder: Path) -> list[Path]:
    """Make ``folder`` and its missing parents; the folders made, outermost first (one
    another process makes meanwhile is not counted as ours)."""
    missing = []
    while not folder.exists() and folder != folder.parent:
        missing.append(folder)
        folder = folder.parent
    made = []
    for d in reversed(missing):
        try:
            d.mkdir()
        except FileExistsError:
            continue
        made.append(d)
    return made


def _remove_empty(made: list[Path]) -> None:
    for d in reversed(made):
        with contextlib.suppress(OSError):        # not empty (someone else's file): kept
            d.rmdir()


def _mode_of(out: Path, tmp: Path) -> None:
    """Give the staged folder ``tmp`` the mode ``out`` has or would get (staged_folder)."""
    if out.is_dir():
        st = out.stat()
        if st.st_gid != tmp.stat().st_gid:
            with contextlib.suppress(OSError):    # a group we are not in: the new folder's
                os.chown(tmp, -1, st.st_gid)
        os.chmod(tmp, stat.S_IMODE(st.st_mode))
        return
    # as mkdir would: the umask's mode, and the set-group-ID bit a parent passes down
    inherited = tmp.stat().st_mode & stat.S_ISGID
    os.chmod(tmp, (0o777 & ~_umask()) | inherited)


def _umask() -> int:
    mask = os.umask(0)  # there is no way to read the umask without setting it
    os.umask(mask)
    return mask


def atomic_write_json(path: str | os.PathLike, obj) -> None:
    """Serialise ``obj`` (numpy-aware) as indented JSON, atomically."""
    atomic_write_text(path, json.dumps(to_jsonable(obj), indent=2) + "\n")


def refuse_formula_cells(df, table) -> None:
    """Raise :class:`InputError` at the first text cell of ``df`` (its column names
    included) that a spreadsheet would run as a formula
    (:func:`~.formula_cells.runs_as_formula`: ``-1.5``, ``+3e-4`` are numbers, written as
    they are).  The message names ``table`` (the output file), the column and the row
    (rows counted from 1, the first data line)."""
    for c in df.columns:
        if runs_as_formula(c):
            raise _formula(table, c, None, c)
    for j, c in enumerate(df.columns):
        i = first_formula_cell(df.iloc[:, j])
        if i is not None:
            raise _formula(table, c, i + 1, df.iloc[i, j])


def _formula(table, column, row, value) -> InputError:
    shown = value if len(value) <= 40 else value[:40] + "..."
    what = "column name" if row is None else "text cell"
    return InputError(f"{what} {shown!r} would be run as a formula by a spreadsheet: "
                      "dpdfit writes no text cell starting with =, +, -, @, a tab or a "
                      "carriage return", file=str(table), column=str(column), row=row)


def csv_table_text(df, table, **to_csv) -> str:
    """``df`` as CSV text (no index; ``to_csv``: further options of
    :meth:`pandas.DataFrame.to_csv`), after :func:`refuse_formula_cells`; ``table``
    names the output in a refusal."""
    refuse_formula_cells(df, table)
    return df.to_csv(index=False, **to_csv)


def write_csv_table(path: str | os.PathLike, df, *, name=None, head: str = "",
                    header: bool = True, mode: str = "w", **to_csv) -> None:
    """Write ``df`` as CSV to ``path`` (not atomically: a file of a staged folder or
    stage), after :func:`refuse_formula_cells` naming ``name`` (default ``path``; the
    final path of a staged file), with the text ``head`` on top; pandas writes the rows
    in chunks, so no copy of the whole text is made.  ``mode="a"`` with
    ``header=False`` appends rows."""
    refuse_formula_cells(df, path if name is None else name)
    with open(path, mode, encoding="utf-8", newline="") as fh:
        fh.write(head)
        df.to_csv(fh, index=False, header=header, **to_csv)


def write_csv_with_header(path: str | os.PathLike, df, meta: dict) -> None:
    """Write a pandas table as CSV with ``# key: <json>`` provenance lines on top, atomically.

    Read it back with :func:`read_csv_with_header` (or
    ``pandas.read_csv(path, comment="#")`` for the table alone).
    """
    header = "".join(f"# {k}: {json.dumps(to_jsonable(v))}\n" for k, v in meta.items())
    atomic_write_text(path, header + csv_table_text(df, path, float_format="%.12g"))


def read_csv_header(path: str | os.PathLike) -> dict:
    """The ``# key: <json>`` lines at the top of a CSV file, as a dict."""
    meta = {}
    with open(path) as fh:
        for line in fh:
            if not line.startswith("#"):
                break
            key, sep, val = line[1:].partition(":")
            if not sep:
                continue
            try:
                meta[key.strip()] = json.loads(val.strip())
            except json.JSONDecodeError:
                meta[key.strip()] = val.strip()
    return meta
