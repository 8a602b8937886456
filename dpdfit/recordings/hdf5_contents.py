"""What dpdfit reads of an HDF5 results file: only the file itself, and only what is used.

An HDF5 file can hold more than its own data: a dataset can keep its raw data
in another file (*external storage*), gather it from other files (a *virtual
dataset*), or be a link into another file (an *external link*) or to another
place in the file (a *soft link*).  A results file that did any of these would
make an import read files the mapping never named and that ``campaign.json``
does not list, so they are refused, in one line naming the dataset, before any
of their data is read.  A soft link to a dataset inside ``datasets/`` is only
another name for it, and is read.

:class:`ResultsFileContents` lists a file's datasets (names and link kinds)
without reading any data, and reads one when asked: its declared size (shape
times element size) first checked against a limit
(:data:`~dpdfit.core.defaults.MAX_DATASET_BYTES`, or the mapping's ``[import]
max_dataset_bytes``), so that a dataset declaring gigabytes it never wrote is
refused, not allocated; its type must be numbers or text.  :func:`check_signature`
reads a file's first 8 bytes only; :func:`file_sha256` streams it.  :func:`h5py_module`
imports h5py, an optional dependency, when a file is first read.
"""

from __future__ import annotations

import hashlib
import math
import posixpath

import numpy as np

from dpdfit.core.defaults import MAX_DATASET_BYTES
from dpdfit.errors import DpdfitError, InputError

__all__ = ["ResultsFileContents", "h5py_module", "check_signature", "file_sha256", "one_value",
           "short_repr", "HDF5_SIGNATURE"]

#: The first 8 bytes of an HDF5 file (ARTIQ writes no user block before them).
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
# What one element of a variable-length dataset (a string, a ragged row) costs at
# least once read: its pointer and a small Python object (a str of a few
# characters is ~50 bytes).  It bounds the element count before the read; the
# elements' own bytes are counted as they are read, a slice at a time.
_VLEN_ELEMENT_BYTES = 64
_VLEN_SLICE_ELEMENTS = 1 << 16
# what h5py raises for a damaged file: a broken link table or chunk, a filter that is
# not installed, an HDF5 type numpy has no match for, a header whose sizes or versions
# make no sense (ValueError), and SystemError, which h5py's lock raises when the HDF5
# library fails inside a call that Python code (a visit's callback) was part of
_H5_ERRORS = (OSError, RuntimeError, KeyError, TypeError, ValueError, SystemError)
_RAISE = "raise it with '[import] max_dataset_bytes = N' in the mapping if the file is right"


def h5py_module():
    """h5py, or a DpdfitError that names the extra to install."""
    try:
        import h5py            # here, not at the top: h5py is optional (the extra 'artiq')
    except ImportError:
        raise DpdfitError("reading ARTIQ results files needs h5py: pip install "
                          "'dpdfit[artiq]' (or pip install h5py)") from None
    return h5py


def check_signature(path, name: str) -> None:
    """Refuse ``path`` unless it starts with the HDF5 signature; reads 8 bytes only."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(len(HDF5_SIGNATURE))
    except OSError as exc:
        raise InputError(f"cannot be read ({exc.strerror})", file=name) from None
    if head != HDF5_SIGNATURE:
        raise InputError("not an HDF5 file (an ARTIQ results file is HDF5)", file=name)


def file_sha256(path, name: str) -> str:
    """The SHA-256 of the file at ``path``, read in blocks (never whole into memory)."""
    try:
        with open(path, "rb") as fh:
            return hashlib.file_digest(fh, "sha256").hexdigest()
    except OSError as exc:
        raise InputError(f"cannot be read ({exc.strerror})", file=name) from None


def one_value(value, key: str, name: str):
    """The one value of dataset ``key`` (a size-1 array gives its element, bytes are
    decoded); InputError naming ``key`` in file ``name`` when it holds several."""
    if isinstance(value, np.ndarray):
        if value.size != 1:
            raise InputError(f"dataset '{key}' is an array of shape {value.shape}, not one "
                             "value", file=name)
        value = value.reshape(())[()]
    if isinstance(value, np.generic):
        value = value.item()
    return value.decode("utf-8", "replace") if isinstance(value, bytes) else value


def short_repr(value) -> str:
    """A value's type and its repr cut to 40 characters, for one-line messages."""
    text = repr(value)
    return f"{type(value).__name__} {text if len(text) <= 40 else text[:37] + '...'}"


def _size(n: int) -> str:
    for unit, factor in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= factor:
            return f"{n / factor:.3g} {unit}"
    return f"{n} bytes"


def _one_line(exc: Exception) -> str:
    # h5py reports an error raised in its own callback (a link name that is not UTF-8,
    # met while listing) as a SystemError about its lock, which holds the error as cause
    while isinstance(exc, SystemError) and (exc.__cause__ or exc.__context__) is not None:
        exc = exc.__cause__ or exc.__context__
    if isinstance(exc, UnicodeDecodeError):
        return f"a name that is not UTF-8 text (byte {exc.start + 1})"
    if isinstance(exc, SystemError):
        return "the HDF5 library failed on it"
    return " ".join(str(exc).split()) or type(exc).__name__


class ResultsFileContents:
    """The datasets of one HDF5 results file, listed without reading, each read on demand.

    The file is opened from its path for each read, or once for a whole ``with``
    block (which may be nested).  Every read goes through links only where they
    stay in the file (module doc) and checks the dataset's storage, type and
    declared size before reading it.

    Parameters
    ----------
    path : path-like
        The results file (its signature already checked: :func:`check_signature`).
    name : str
        How messages name the file.
    max_dataset_bytes : int, optional
        The largest dataset read, in bytes (default
        :data:`~dpdfit.core.defaults.MAX_DATASET_BYTES`).
    """

    def __init__(self, path, name: str, max_dataset_bytes: int | None = None):
        self.h5py = h5py_module()
        self.path, self.name = path, name
        self.max_dataset_bytes = int(MAX_DATASET_BYTES if max_dataset_bytes is None
                                     else max_dataset_bytes)
        self._file, self._depth, self._opened = None, 0, {}
        #: name -> (kind, target) under ``datasets/`` (:meth:`_listing`), once opened
        self.links = None

    def __enter__(self):
        if self._depth == 0:
            try:
                # no HDF5 file lock: reading never writes, and a lock fails on read-only
                # mounts and on a file the ARTIQ master still holds
                self._file = self.h5py.File(self.path, "r", locking=False)
            except _H5_ERRORS as exc:
                raise InputError(f"not a readable HDF5 file ({_one_line(exc)})",
                                 file=self.name) from None
            if self.links is None:
                try:
                    self.links = self._listing()
                except BaseException as exc:
                    self._file.close()
                    self._file = None
                    if isinstance(exc, _H5_ERRORS):
                        raise InputError(f"group 'datasets' cannot be listed "
                                         f"({_one_line(exc)})", file=self.name) from None
                    raise
        self._depth += 1
        return self

    def __exit__(self, *exc_info):
        self._depth -= 1
        if self._depth == 0:
            self._opened.clear()
            self._file.close()
            self._file = None

    def _refuse(self, msg: str):
        raise InputError(msg, file=self.name)

    def _listing(self) -> dict:
        """name -> (kind, target) of everything under ``datasets/``, no link followed:
        kind is "dataset", "group", "soft", "external" or "other"."""
        h5py, f = self.h5py, self._file
        link = f.get("datasets", getlink=True)
        if link is None:
            return {}
        if not isinstance(link, h5py.HardLink):
            self._refuse(f"'datasets' is {_link_kind(h5py, link)}: dpdfit reads only the "
                         "results file itself")
        group = f["datasets"]
        if not isinstance(group, h5py.Group):
            self._refuse("'datasets' is a dataset, not a group (ARTIQ keeps one dataset per "
                         "key in the group 'datasets')")
        out, failed = {}, []

        def visit(name, link):
            try:
                if isinstance(link, h5py.HardLink):
                    cls = group.get(name, getclass=True)
                    out[name] = ("dataset" if cls is h5py.Dataset else
                                 "group" if cls is h5py.Group else "other", None)
                elif isinstance(link, h5py.SoftLink):
                    out[name] = ("soft", link.path)
                elif isinstance(link, h5py.ExternalLink):
                    out[name] = ("external", f"'{link.path}' in the file '{link.filename}'")
                else:
                    out[name] = ("other", None)
            except _H5_ERRORS as exc:
                # an error raised inside the visit comes back from HDF5 as a SystemError
                # that hides it: kept here, and the visit stopped (a value other than None)
                failed.append((name, exc))
                return True
            return None

        group.visititems_links(visit)
        if failed:
            name, exc = failed[0]
            self._refuse(f"group 'datasets' cannot be listed (at '{name}': "
                         f"{_one_line(exc)})")
        return out

    def names(self) -> list:
        """The names under ``datasets/`` that are not groups (links included)."""
        if self.links is None:
            with self:
                pass                                 # lists the file
        return [k for k, (kind, _) in self.links.items() if kind != "group"]

    def read(self, name: str) -> tuple:
        """``(value, attributes)`` of dataset ``datasets/<name>`` (InputError if refused)."""
        where = f"dataset '{name}'"
        with self:
            return self._read(self._resolved(name), where, with_attrs=True)

    def _resolved(self, name: str) -> tuple:
        """The path (parts) of the dataset ``datasets/<name>`` names, through a soft link
        only to another dataset in ``datasets/``; InputError for any other link."""
        kind, target = self.links[name]
        where = f"dataset '{name}'"
        if kind == "external":
            self._refuse(f"{where} is an external link to {target}: dpdfit reads only the "
                         "results file itself")
        path = name
        if kind == "soft":
            full = posixpath.normpath(posixpath.join("/datasets", posixpath.dirname(name),
                                                     target))
            path = full[len("/datasets/"):]
            if not full.startswith("/datasets/") or \
                    self.links.get(path, ("",))[0] != "dataset":
                self._refuse(f"{where} is a soft link to '{target}', not to a dataset in "
                             "'datasets/': dpdfit reads only the datasets of the run")
        elif kind != "dataset":
            self._refuse(f"{where} is {'a group' if kind == 'group' else 'not a dataset'}, "
                         "not a value")
        return ("datasets", *path.split("/"))

    def read_top(self, key: str):
        """The value of the top-level dataset ``key`` (``rid``, ``expid``, ...), or None
        when the file has none."""
        with self:
            try:
                if self._file.get(key, getlink=True) is None:
                    return None
            except _H5_ERRORS as exc:
                self._refuse(f"dataset '{key}' cannot be read ({_one_line(exc)})")
            return self._read((key,), f"dataset '{key}'", with_attrs=False)

    def declared_shape(self, name: str):
        """The shape dataset ``datasets/<name>`` declares (no data read), or None when
        it has none or is a link that :meth:`read` refuses (refused when read)."""
        try:
            with self:
                return self._walk(self._resolved(name), f"dataset '{name}'").shape
        except (InputError, *_H5_ERRORS):
            return None

    def _walk(self, parts: tuple, where: str):
        """The dataset at ``parts``, reached through hard links only: checked again in
        every opening of the file (it may have changed since it was listed), the
        objects reached kept while it is open."""
        h5py = self.h5py
        node = self._file
        for i, part in enumerate(parts):
            if parts[:i + 1] in self._opened:
                node = self._opened[parts[:i + 1]]
                continue
            if node.id.links.exists(part.encode()) and \
                    node.id.links.get_info(part.encode()).type == h5py.h5l.TYPE_HARD:
                node = self._opened[parts[:i + 1]] = node[part]
                continue
            link = node.get(part, getlink=True)
            what = "missing" if link is None else _link_kind(h5py, link)
            self._refuse(f"{where}: '{'/'.join(parts[:i + 1])}' is {what}")
        if not isinstance(node, h5py.Dataset):
            self._refuse(f"{where} is a group, not a value")
        return node

    def _read(self, parts: tuple, where: str, with_attrs: bool):
        try:
            d = self._walk(parts, where)
            self._check(d, where)
            value = self._values(d, where)
            attrs = self._attrs(d, where) if with_attrs else None
        except _H5_ERRORS as exc:
            self._refuse(f"{where} cannot be read ({_one_line(exc)})")
        return (value, attrs) if with_attrs else value

    def _check(self, d, where: str) -> None:
        """Refuse, before any data is read, what is not in the file or not numbers or text,
        and what declares more bytes than the limit."""
        plist = d.id.get_create_plist()
        if plist.get_layout() == self.h5py.h5d.VIRTUAL:
            self._refuse(f"{where} is a virtual dataset (its data is gathered from other "
                         "files): dpdfit reads only the results file itself")
        if plist.get_external_count() > 0:
            other = plist.get_external(0)[0].decode("utf-8", "replace")
            self._refuse(f"{where} keeps its data outside the results file (HDF5 external "
                         f"storage in '{other}'): dpdfit reads only the results file itself")
        if d.shape is None:
            self._refuse(f"{where} holds no value (an empty HDF5 dataspace)")
        problem = _type_problem(self.h5py, d.dtype)
        if problem:
            self._refuse(f"{where} {problem}: dpdfit reads numbers and text")
        self._check_size(d.shape, d.dtype, where)

    def _check_size(self, shape, dtype, where: str) -> None:
        n = math.prod(shape or ())
        vlen = dtype.kind == "O"
        declared = n * (_VLEN_ELEMENT_BYTES if vlen else dtype.itemsize)
        if declared > self.max_dataset_bytes:
            what = (f"{n} variable-length elements" if vlen else
                    f"shape {tuple(shape)} of {dtype}")
            self._refuse(f"{where} declares {_size(declared)} ({what}), over the limit of "
                         f"{_size(self.max_dataset_bytes)} ({self.max_dataset_bytes} bytes) a "
                         f"dataset may have: {_RAISE}")

    def _values(self, d, where: str):
        if d.dtype.kind != "O" or d.ndim == 0:
            return _plain(d[()])
        # variable-length: the elements' bytes are known only as they are read
        out = np.empty(d.shape, dtype=object)
        step = max(1, _VLEN_SLICE_ELEMENTS // max(1, math.prod(d.shape[1:])))
        total = 0
        for start in range(0, d.shape[0], step):
            part = d[start:start + step]
            total += sum(len(x) if isinstance(x, bytes) else np.asarray(x).nbytes
                         for x in part.ravel())
            if total > self.max_dataset_bytes:
                self._refuse(f"{where} holds more than {_size(self.max_dataset_bytes)} of "
                             f"variable-length data, the limit a dataset may have: {_RAISE}")
            out[start:start + step] = part
        return _plain(out)

    def _attrs(self, d, where: str) -> dict:
        out = {}
        for key in d.attrs:
            aid = d.attrs.get_id(key)
            self._check_size(aid.shape, aid.dtype, f"{where}, attribute '{key}'")
            out[key] = d.attrs[key]
        return out


def _link_kind(h5py, link) -> str:
    if isinstance(link, h5py.SoftLink):
        return f"a soft link to '{link.path}'"
    if isinstance(link, h5py.ExternalLink):
        return f"an external link to '{link.path}' in the file '{link.filename}'"
    return "a link of a kind dpdfit does not follow"


def _type_problem(h5py, dtype) -> str | None:
    """Why values of ``dtype`` are not numbers or text (None when they are)."""
    if h5py.check_ref_dtype(dtype) is not None:
        return "holds HDF5 references (to other objects)"
    if h5py.check_string_dtype(dtype) is not None:
        return None
    base = h5py.check_vlen_dtype(dtype)
    if base is not None:
        return None if base.kind in "biuf" else f"holds variable-length sequences of {base}"
    if dtype.fields is not None:
        return f"holds records of several fields (compound type {dtype})"
    if dtype.kind in "biufcS":
        return None             # complex is read as it is; a column refuses it (mapped_columns)
    return f"holds values of type {dtype}"


def _plain(v):
    """Text as ``str`` (HDF5 variable-length strings come back as bytes)."""
    if isinstance(v, bytes):
        return v.decode("utf-8", errors="replace")
    if isinstance(v, np.ndarray) and v.dtype.kind == "O":
        # filled element by element: np.array() of equal-length arrays (a per-shot
        # channel whose points all have no shot) would stack them into one 2-D array
        out = np.empty(v.size, dtype=object)
        out[:] = [x.decode("utf-8", "replace") if isinstance(x, bytes) else x
                  for x in v.ravel()]
        return out.reshape(v.shape)
    return v
