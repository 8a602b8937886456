"""The one reader of files from elsewhere: every file a command is given, or finds in a
folder it is given, is read through here.

A campaign folder, new recordings, a schedule, a mapping or an earlier diagnosis may come
from another lab, or be damaged.  Before a byte of it is read, the file must be

* a regular file: a FIFO would block the read forever, a device (``/dev/zero``) never
  ends, a folder is not a file;
* inside the folder the user named (``within``): a symbolic link may point elsewhere in
  that folder, never out of it, so a link in a collaborator's folder to a file of the
  reader's own (``notes.txt -> ~/.ssh/id_rsa``) is refused, not read or copied;
* at most as large as the bound of its kind (:data:`~dpdfit.core.defaults.MAX_INPUT_BYTES`,
  set for one run with the environment variable ``DPDFIT_MAX_INPUT_BYTES``;
  :data:`~dpdfit.core.defaults.MAX_JSON_BYTES` for JSON), checked on the open file and
  again while it is read, so a file that grows, or a sparse file that declares far more
  than it holds, is refused instead of filling the memory.

Each refusal is one :class:`~dpdfit.errors.InputError` naming the file.  The file is
opened once (non-blocking, so a FIFO put in its place after the check cannot hang the
read) and checked on that open file.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import stat
import sys
from pathlib import Path

from dpdfit.core.defaults import (MAX_INPUT_BYTES, MAX_INPUT_BYTES_VARIABLE, MAX_JSON_BYTES,
                                  MAX_JSON_DEPTH)
from dpdfit.errors import InputError

__all__ = ["max_input_bytes", "format_bytes", "check_inside", "checked_input", "open_input",
           "read_input_bytes", "read_input_chunks", "read_input_text", "read_input_json",
           "json_depth", "copy_input_file"]


def max_input_bytes() -> int:
    """The largest input file dpdfit reads in this run: ``DPDFIT_MAX_INPUT_BYTES`` when set
    (an InputError when it is not a positive integer), else
    :data:`~dpdfit.core.defaults.MAX_INPUT_BYTES`."""
    text = os.environ.get(MAX_INPUT_BYTES_VARIABLE)
    if text is None or not text.strip():
        return MAX_INPUT_BYTES
    try:
        value = int(text.strip())
    except ValueError:
        value = 0
    if value <= 0:
        raise InputError(f"the environment variable {MAX_INPUT_BYTES_VARIABLE} must be a "
                         f"positive number of bytes, not {text.strip()[:40]!r}")
    return value


def format_bytes(n: int) -> str:
    """A size as a person writes it: ``"1.5 GB"``, ``"64 MiB"`` for a power of two."""
    n = int(n)
    for unit, size in (("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if n >= size and n % size == 0:
            return f"{n // size} {unit}"
    for unit, size in (("GB", 10**9), ("MB", 10**6), ("kB", 10**3)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n} bytes"


def _kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def check_inside(path, within, what: str = "file") -> Path:
    """``path`` resolved (its links followed), or an InputError when it is, or leads
    through a link, outside the folder ``within`` (also resolved), or a link loop."""
    name = str(path)
    try:
        real = Path(os.path.realpath(path, strict=False))
        root = Path(os.path.realpath(within, strict=False))
        # realpath does not raise on a loop: resolve strictly to tell one
        Path(path).resolve(strict=os.path.lexists(path))
    except RuntimeError:
        raise InputError("is a symbolic link loop", file=name) from None
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise InputError("is a symbolic link loop", file=name) from None
        raise InputError(f"cannot be read ({exc.strerror or exc})", file=name) from None
    if real != root and root not in real.parents:
        raise InputError(f"leads out of {within} (to {real}): dpdfit reads a {what} only "
                         f"inside the folder it is given and follows no link out of it",
                         file=name)
    return real


def checked_input(path, *, within=None, what: str = "file") -> Path:
    """``path`` as a regular file that exists (and, with ``within``, lies inside that
    folder), resolved; an InputError naming it otherwise.  Nothing of the file is read,
    and it is not opened (a FIFO is refused on its type)."""
    name = str(path)
    if within is not None:
        check_inside(path, within, what)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        if os.path.islink(path):
            raise InputError(f"is a symbolic link to a {what} that does not exist",
                             file=name) from None
        raise InputError(f"{what} not found", file=name) from None
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise InputError("is a symbolic link loop", file=name) from None
        raise InputError(f"cannot be read ({exc.strerror or exc})", file=name) from None
    if not stat.S_ISREG(st.st_mode):
        raise InputError(f"is {_kind(st.st_mode)}, not a {what}: dpdfit reads regular files "
                         "only", file=name)
    return Path(os.path.realpath(path))


def _too_large(size: int, limit: int, name: str, json_file: bool) -> InputError:
    how = ("" if json_file else
           f"; the environment variable {MAX_INPUT_BYTES_VARIABLE} raises the limit")
    return InputError(f"is {format_bytes(size)}, more than the {format_bytes(limit)} dpdfit "
                      f"reads from one {'JSON ' if json_file else ''}file{how}", file=name)


@contextlib.contextmanager
def open_input(path, *, within=None, what: str = "file", limit: int | None = None,
               json_file: bool = False):
    """The input file ``path`` (module doc) open for reading in binary, checked on the open
    file: a regular file, inside ``within`` when given, at most ``limit`` bytes (default
    :func:`max_input_bytes`).  For a reader that needs only part of the file (a header)
    or streams it; it reads at most ``limit`` bytes.  Each refusal is an InputError
    naming the file."""
    name = str(path)
    limit = max_input_bytes() if limit is None else int(limit)
    real = checked_input(path, within=within, what=what)
    try:
        # non-blocking: a FIFO swapped in after the check must not hang the open
        fd = os.open(real, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as exc:
        raise InputError(f"cannot be read ({exc.strerror or exc})", file=name) from None
    with os.fdopen(fd, "rb") as fh:
        st = os.fstat(fh.fileno())
        if not stat.S_ISREG(st.st_mode):
            raise InputError(f"is {_kind(st.st_mode)}, not a {what}: dpdfit reads regular "
                             "files only", file=name)
        if st.st_size > limit:
            raise _too_large(st.st_size, limit, name, json_file)
        yield fh


def read_input_bytes(path, *, within=None, what: str = "file", limit: int | None = None,
                     json_file: bool = False) -> bytes:
    """The bytes of the input file ``path`` (module doc): a regular file, inside
    ``within`` when given, at most ``limit`` bytes (default :func:`max_input_bytes`).
    Each refusal is an InputError naming the file."""
    name = str(path)
    limit = max_input_bytes() if limit is None else int(limit)
    with open_input(path, within=within, what=what, limit=limit, json_file=json_file) as fh:
        try:
            # as many bytes as the file holds (one more tells a file that grows): a read of
            # the bound itself would set aside a gigabyte for a file of a few bytes
            size = os.fstat(fh.fileno()).st_size
            parts = [fh.read(min(size, limit) + 1)]
            n = len(parts[0])
            while size < n <= limit:          # it grew: read on, to one byte past the bound
                part = fh.read(min(1 << 20, limit + 1 - n))
                if not part:
                    break
                parts.append(part)
                n += len(part)
        except OSError as exc:
            raise InputError(f"cannot be read ({exc.strerror or exc})", file=name) from None
    data = parts[0] if len(parts) == 1 else b"".join(parts)
    if len(data) > limit:                     # it grew while it was read
        raise _too_large(len(data), limit, name, json_file)
    return data


def read_input_chunks(path, *, within=None, what: str = "file", limit: int | None = None,
                      size: int = 1 << 20):
    """The input file ``path`` (checked by :func:`open_input`) as successive chunks of at
    most ``size`` bytes, for a reader that may refuse the file part way through (a table
    with too many rows) without reading the rest; an InputError naming it when it holds
    more than ``limit`` bytes (it grew while it was read).  The file is closed when the
    reader stops, early or not."""
    name = str(path)
    limit = max_input_bytes() if limit is None else int(limit)
    with open_input(path, within=within, what=what, limit=limit) as fh:
        n = 0
        while True:
            try:
                chunk = fh.read(min(int(size), limit + 1 - n))
            except OSError as exc:
                raise InputError(f"cannot be read ({exc.strerror or exc})", file=name) from None
            if not chunk:
                return
            n += len(chunk)
            if n > limit:
                raise _too_large(n, limit, name, False)
            yield chunk


def read_input_text(path, *, within=None, what: str = "file",
                    limit: int | None = None) -> str:
    """The input file ``path`` as UTF-8 text (a leading byte-order mark dropped), read by
    :func:`read_input_bytes`; an InputError naming it when it is not UTF-8 text."""
    data = read_input_bytes(path, within=within, what=what, limit=limit)
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(f"is not UTF-8 text (byte {exc.start + 1})", file=str(path)) from None


def json_depth(value, stop: int | None = None) -> int:
    """The levels of lists and objects in the JSON value ``value`` (a number or text: 0),
    counted without recursion; with ``stop``, counting ends at the first level beyond it
    (the result is then ``stop + 1``)."""
    deepest, level, todo = 0, 0, [value]
    while todo:
        level += 1
        deeper = []
        for v in todo:
            if isinstance(v, dict):
                deeper.extend(v.values())
            elif isinstance(v, list):
                deeper.extend(v)
            else:
                continue
            deepest = level
        if stop is not None and deepest > stop:
            return deepest
        todo = deeper
    return deepest


def read_input_json(path, *, within=None, what: str = "JSON file",
                    limit: int = MAX_JSON_BYTES, max_depth: int | None = MAX_JSON_DEPTH,
                    not_json: str = "is not JSON"):
    """The JSON value of the input file ``path``: read by :func:`read_input_bytes` (at most
    ``limit`` bytes); an InputError naming the file (and the line) when it is not JSON or
    is nested deeper than ``max_depth`` levels of lists and objects
    (:data:`~dpdfit.core.defaults.MAX_JSON_DEPTH`; None: as deep as the parser reads),
    which the code walking the value could not follow.  ``not_json``: how the refusal of
    text the parser rejects begins (a reader keeps the wording its users know), followed
    by the parser's reason and line."""
    name = str(path)
    data = read_input_bytes(path, within=within, what=what, limit=limit, json_file=True)
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(f"is not UTF-8 text (byte {exc.start + 1})", file=name) from None
    try:
        value = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{not_json} ({exc.msg}, line {exc.lineno})", file=name) from None
    except RecursionError:
        raise InputError("is nested too deeply to be read as JSON", file=name) from None
    except ValueError:                # an integer of more digits than Python converts
        raise InputError("holds a number too long to read (more than "
                         f"{sys.get_int_max_str_digits()} digits)", file=name) from None
    if max_depth is not None and json_depth(value, max_depth) > max_depth:
        raise InputError(f"is nested too deeply: lists and objects more than {max_depth} "
                         f"levels deep, the most dpdfit reads from a {what}", file=name)
    return value


def copy_input_file(path, dest, *, within=None, what: str = "file",
                    limit: int | None = None) -> int:
    """Copy the input file ``path`` (checked by :func:`open_input`) to a new regular file
    ``dest``, written fresh (never a link, nor a copy of one), in chunks: at most
    ``limit`` bytes, an InputError naming ``path`` when it holds more (it grew while it
    was copied).  Returns the bytes copied."""
    limit = max_input_bytes() if limit is None else int(limit)
    with open_input(path, within=within, what=what, limit=limit) as src, \
            open(dest, "xb") as out:
        n = 0
        while True:
            try:
                chunk = src.read(min(1 << 20, limit + 1 - n))
            except OSError as exc:
                raise InputError(f"cannot be read ({exc.strerror or exc})",
                                 file=str(path)) from None
            if not chunk:
                return n
            n += len(chunk)
            if n > limit:
                raise _too_large(n, limit, str(path), False)
            out.write(chunk)
