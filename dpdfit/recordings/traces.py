"""Photodiode trace files (``.npy``, ``.npz``, one-column ``.csv``) -> validated samples.

:func:`load_trace` reads a recorded heterodyne trace; :func:`as_trace` checks
samples already in memory (1-D, real, finite) and converts them to float64.
A trace file may come from elsewhere: it is read through
:mod:`dpdfit.recordings.input_files`, and :func:`check_trace_file` refuses, from its
header alone, an array larger than the bound (a compressed ``.npz`` may declare far
more samples than it holds).
Both raise :class:`~dpdfit.errors.InputError` naming the file and, for a bad
value, the 1-based row (sample) number.
"""

from __future__ import annotations

import io
import math
import os
import zipfile
import zlib
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.lib import format as npy_format

from dpdfit.core.defaults import MAX_INPUT_BYTES_VARIABLE
from dpdfit.core.memory import TRACE_BYTES_PER_SAMPLE, check_memory
from dpdfit.errors import InputError

from .input_files import format_bytes, max_input_bytes, open_input, read_input_bytes

__all__ = ["load_trace", "check_trace_file", "as_trace"]


def as_trace(trace, *, file: str | None = None) -> np.ndarray:
    """1-D finite float64 samples, or InputError (row = 1-based sample number).

    Parameters
    ----------
    trace : array_like, shape (N,) or (N, 1)
        Real (integer or float) samples.
    file : str, optional
        File name to put in an error message.
    """
    arr = np.asarray(trace)
    if arr.ndim == 2 and arr.shape[1] == 1:
        arr = arr[:, 0]
    if arr.ndim != 1:
        raise InputError(f"trace must be a 1-D array of samples, got shape {arr.shape}",
                         file=file)
    if arr.dtype.kind == "c":
        raise InputError("trace is complex; expected the real photodiode samples", file=file)
    if arr.dtype.kind not in "iuf":
        raise InputError(f"trace must hold real numbers, got dtype {arr.dtype}", file=file)
    if arr.size == 0:
        raise InputError("trace contains no samples", file=file)
    check_memory(arr.size * TRACE_BYTES_PER_SAMPLE, f"a trace of {arr.size} samples", file=file,
                 hint="analyse a shorter record or set DPDFIT_MAX_MEMORY_GB")
    x = np.asarray(arr, dtype=np.float64)   # float32/int16 -> float64 (never compute in single)
    if not np.isfinite(x).all():
        i = int(np.flatnonzero(~np.isfinite(x))[0])
        raise InputError(f"sample is {x[i]} (must be finite)", file=file, row=i + 1)
    return x


def _load_csv(data: bytes, name: str) -> np.ndarray:
    nul = data.find(b"\0")
    if nul >= 0:
        raise InputError(f"holds a NUL byte (byte {nul + 1}): not a text file of samples (a "
                         "binary file, or a sparse file read as zeros?)", file=name)
    first = None
    for line in io.BytesIO(data):
        s = line.decode("utf-8", errors="replace").strip()
        if s and not s.startswith("#"):
            first = s
            break
    if first is None:
        raise InputError("file is empty (no samples)", file=name)
    ncols = len(first.split(","))
    if ncols != 1:
        raise InputError(f"{ncols} columns in the first line; expected one column of samples",
                         file=name)
    try:
        float(first)
        header = None
    except ValueError:
        header = 0
    kw = dict(header=header, comment="#", skipinitialspace=True, skip_blank_lines=True)
    try:
        df = pd.read_csv(io.BytesIO(data), dtype=np.float64, **kw)
        col = None if header is None else str(df.columns[0]).strip()
    except UnicodeDecodeError as exc:
        raise InputError(f"not UTF-8 text (byte {exc.start + 1})", file=name) from None
    except pd.errors.EmptyDataError:
        raise InputError("file is empty (no samples)", file=name) from None
    except (ValueError, pd.errors.ParserError) as exc:
        if isinstance(exc, pd.errors.ParserError):
            msg = str(exc).strip().splitlines()[-1]
            raise InputError(f"more than one column? ({msg})", file=name) from None
        raw = pd.read_csv(io.BytesIO(data), dtype=str, keep_default_na=False, **kw)
        col = None if header is None else str(raw.columns[0]).strip()
        text = raw.iloc[:, 0].astype(str).str.strip()
        vals = pd.to_numeric(text, errors="coerce")
        bad = np.flatnonzero(vals.isna().to_numpy())
        if bad.size == 0:  # pragma: no cover - pandas refused a column it can parse
            raise InputError(f"not a readable CSV file ({exc})", file=name) from None
        i = int(bad[0])
        t = text.iloc[i]
        shown = repr(t[:60]) if ("\n" in t or "\r" in t or len(t) > 60) else f"'{t}'"
        what = "value is empty" if t == "" else f"{shown} is not a number"
        raise InputError(what, file=name, column=col, row=i + 1) from None
    if df.shape[1] != 1:
        raise InputError(f"{df.shape[1]} columns; expected one column of samples", file=name)
    if df.shape[0] == 0:
        raise InputError("file has a header but no samples", file=name)
    x = df.iloc[:, 0].to_numpy(dtype=np.float64)
    bad = ~np.isfinite(x)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"value is {x[i]} (must be finite)", file=name, column=col, row=i + 1)
    return x


def _load_npz(z, name: str) -> tuple[np.ndarray, float]:
    """``(trace, scale)`` from an open ``.npz`` (key ``trace``, optional ``scale``)."""
    keys = list(z.keys())
    if "trace" not in keys:
        raise InputError(f"no array 'trace' in the .npz (keys: {keys})", file=name)
    try:
        arr = z["trace"]
        sc = z["scale"] if "scale" in keys else None
    except ValueError as exc:
        raise InputError(f"not a numeric array ({exc})", file=name) from None
    except (zipfile.BadZipFile, zlib.error, OSError, EOFError) as exc:
        # a damaged archive: a flipped byte fails the member's CRC or its inflation
        raise InputError(f"not a readable .npz archive ({exc})", file=name) from None
    scale = 1.0
    if sc is not None:
        sc = np.asarray(sc)
        if sc.size != 1 or sc.dtype.kind not in "iuf":
            raise InputError(f"'scale' must be one real number, got shape {sc.shape} "
                             f"dtype {sc.dtype}", file=name)
        scale = float(sc.reshape(()))
        if not math.isfinite(scale) or scale == 0:
            raise InputError(f"'scale' must be finite and nonzero, got {scale}", file=name)
    return arr, scale


def _array_header(fh) -> tuple[tuple, np.dtype] | None:
    """``(shape, dtype)`` the ``.npy`` header at ``fh``'s position declares (the data not
    read), None when it is not a ``.npy`` header (the loader says why)."""
    try:
        version = npy_format.read_magic(fh)
        read = (npy_format.read_array_header_1_0 if version == (1, 0)
                else npy_format.read_array_header_2_0)
        shape, _, dtype = read(fh)
    except (ValueError, OSError, EOFError, SyntaxError, TypeError):
        return None
    return tuple(int(n) for n in shape), np.dtype(dtype)


def _check_declared(shape: tuple, dtype: np.dtype, name: str, what: str) -> None:
    """Refuse an array whose declared size exceeds the input bound or the memory its
    analysis would need, before a sample of it is read."""
    samples = math.prod(shape)
    limit = max_input_bytes()
    if samples * max(dtype.itemsize, 1) > limit:
        raise InputError(f"{what} declares {samples:,} samples of {dtype.itemsize} bytes "
                         f"(shape {shape}), more than the {format_bytes(limit)} dpdfit reads "
                         f"from one file; the environment variable {MAX_INPUT_BYTES_VARIABLE} "
                         "raises the limit", file=name)
    check_memory(samples * TRACE_BYTES_PER_SAMPLE, f"a trace of {samples} samples", file=name,
                 hint="analyse a shorter record or set DPDFIT_MAX_MEMORY_GB")


def _check_npz(fh, name: str) -> None:
    """The arrays ``trace`` and ``scale`` of an ``.npz`` within the bounds, from their
    headers, then read through (not kept) so that a damaged member (its CRC, its
    compressed stream) is refused here, not when the traces are analysed.  A file that
    is not a zip archive, or a member that is not there or not an array, is left to the
    loader."""
    try:
        zf = zipfile.ZipFile(fh)
    except (zipfile.BadZipFile, OSError, ValueError, EOFError):
        return
    limit = max_input_bytes()
    with zf:
        for key in ("trace", "scale"):
            try:
                info = zf.getinfo(f"{key}.npy")
            except KeyError:
                continue
            if info.file_size > limit:
                raise InputError(f"the array '{key}' is {format_bytes(info.file_size)} "
                                 f"uncompressed, more than the {format_bytes(limit)} dpdfit "
                                 f"reads from one file; the environment variable "
                                 f"{MAX_INPUT_BYTES_VARIABLE} raises the limit", file=name)
            try:
                with zf.open(info) as member:
                    header = _array_header(member)
                    if header is not None:
                        shape, dtype = header
                        if key == "scale" and math.prod(shape) != 1:
                            raise InputError(f"'scale' must be one real number, got shape "
                                             f"{shape} dtype {dtype}", file=name)
                        _check_declared(shape, dtype, name, f"the array '{key}'")
                    while member.read(1 << 20):     # at most file_size bytes, CRC checked
                        pass
            except (zipfile.BadZipFile, zlib.error, OSError, EOFError,
                    NotImplementedError) as exc:
                raise InputError(f"not a readable .npz archive ({exc})", file=name) from None


def check_trace_file(path, *, within=None) -> None:
    """Refuse, before any sample is read, a trace file that is not a regular file (inside
    ``within`` when given), is larger than
    :func:`~dpdfit.recordings.input_files.max_input_bytes`, or (``.npy``, ``.npz``)
    declares an array larger than that bound or than the memory its analysis would need
    (:func:`~dpdfit.core.memory.check_memory`): a compressed ``.npz`` of a megabyte may
    declare 10^8 samples.  Only the headers are read; a file whose header cannot be read
    is left to :func:`load_trace`, which says why."""
    name = str(path)
    with open_input(path, within=within, what="trace file") as fh:
        ext = Path(path).suffix.lower()
        if ext == ".npy":
            header = _array_header(fh)
            if header is not None:
                _check_declared(*header, name, "the array")
        elif ext == ".npz":
            _check_npz(fh, name)


def load_trace(path: str | os.PathLike, *, within=None) -> np.ndarray:
    """Read a photodiode trace.

    Parameters
    ----------
    path : path-like
        * ``.npy``: a 1-D (or ``(N, 1)``) integer or float array;
        * ``.npz``: key ``trace`` (as above) and optional ``scale`` (finite,
          nonzero scalar, e.g. volts per ADC count) that multiplies it;
        * ``.csv`` / ``.txt``: one column of numbers, header line optional,
          ``#`` lines are comments.
    within : path-like, optional
        The folder the file must lie in (a campaign folder).

    Returns
    -------
    ndarray, shape (N,), float64

    Raises
    ------
    InputError
        Missing file, not a regular file, outside ``within``, larger than the input
        bound or declaring a larger array (:func:`check_trace_file`), unsupported
        type, wrong shape or dtype, more than one column, empty, non-numeric or
        non-finite values (the message names the file and, for a value, the 1-based
        row / sample number).
    """
    p = Path(path)
    name = str(path)
    ext = p.suffix.lower()
    if ext in (".csv", ".txt"):
        return _load_csv(read_input_bytes(path, within=within, what="trace file"), name)
    check_trace_file(path, within=within)
    if ext not in (".npy", ".npz"):
        raise InputError(f"unsupported file type '{p.suffix}'; expected .npy, .npz or a "
                         "one-column .csv", file=name)
    with open_input(path, within=within, what="trace file") as fh:
        try:
            obj = np.load(fh, allow_pickle=False)
        except ValueError as exc:
            raise InputError(f"not a numeric NumPy file ({str(exc).splitlines()[0]})",
                             file=name) from None
        except (OSError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
            raise InputError(f"not a readable NumPy file ({exc})", file=name) from None
        scale = 1.0
        if ext == ".npz" or not isinstance(obj, np.ndarray):
            with obj as z:
                arr, scale = _load_npz(z, name)
        else:
            arr = obj
    x = as_trace(arr, file=name)
    if scale == 1.0:
        return x
    with np.errstate(over="ignore"):
        x = x * scale
    if not np.isfinite(x).all():
        i = int(np.flatnonzero(~np.isfinite(x))[0])
        raise InputError(f"sample x 'scale' = {scale:g} overflows (not finite)", file=name,
                         row=i + 1)
    return x
