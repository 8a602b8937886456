"""Photodiode trace files (``.npy``, ``.npz``, one-column ``.csv``) -> validated samples.

:func:`load_trace` reads a recorded heterodyne trace; :func:`as_trace` checks
samples already in memory (1-D, real, finite) and converts them to float64.
Both raise :class:`~dpdfit.errors.InputError` naming the file and, for a bad
value, the 1-based row (sample) number.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pandas as pd

from dpdfit.core.memory import TRACE_BYTES_PER_SAMPLE, check_memory
from dpdfit.errors import InputError

from .tables import require_file

__all__ = ["load_trace", "as_trace"]


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


def _load_csv(path: Path) -> np.ndarray:
    name = str(path)
    first = None
    with open(path, encoding="utf-8", errors="replace") as fh:
        for line in fh:
            s = line.strip()
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
        df = pd.read_csv(path, dtype=np.float64, **kw)
        col = None if header is None else str(df.columns[0]).strip()
    except UnicodeDecodeError as exc:
        raise InputError(f"not UTF-8 text (byte {exc.start + 1})", file=name) from None
    except pd.errors.EmptyDataError:
        raise InputError("file is empty (no samples)", file=name) from None
    except (ValueError, pd.errors.ParserError) as exc:
        if isinstance(exc, pd.errors.ParserError):
            msg = str(exc).strip().splitlines()[-1]
            raise InputError(f"more than one column? ({msg})", file=name) from None
        raw = pd.read_csv(path, dtype=str, keep_default_na=False, **kw)
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


def load_trace(path: str | os.PathLike) -> np.ndarray:
    """Read a photodiode trace.

    Parameters
    ----------
    path : path-like
        * ``.npy``: a 1-D (or ``(N, 1)``) integer or float array;
        * ``.npz``: key ``trace`` (as above) and optional ``scale`` (finite,
          nonzero scalar, e.g. volts per ADC count) that multiplies it;
        * ``.csv`` / ``.txt``: one column of numbers, header line optional,
          ``#`` lines are comments.

    Returns
    -------
    ndarray, shape (N,), float64

    Raises
    ------
    InputError
        Missing file, unsupported type, wrong shape or dtype, more than one
        column, empty, non-numeric or non-finite values (the message names
        the file and, for a value, the 1-based row / sample number).
    """
    p = Path(path)
    name = require_file(path)
    ext = p.suffix.lower()
    if ext in (".csv", ".txt"):
        return _load_csv(p)
    if ext not in (".npy", ".npz"):
        raise InputError(f"unsupported file type '{p.suffix}'; expected .npy, .npz or a "
                         "one-column .csv", file=name)
    try:
        obj = np.load(p, allow_pickle=False)
    except ValueError as exc:
        raise InputError(f"not a numeric NumPy file ({str(exc).splitlines()[0]})",
                         file=name) from None
    except (OSError, EOFError) as exc:
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
