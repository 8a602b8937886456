"""Recordings -> validated tables.

Every CSV that enters dpdfit passes through :func:`read_table`, which checks
it once and completely, so that the fitting code never sees a malformed value.
A problem is reported as one :class:`~dpdfit.errors.InputError` line naming the
file, the column and the data row (row 1 is the first line after the header;
``#`` comment lines and blank lines are not counted) and, through
:class:`~dpdfit.errors.InputError`, the file's line number of that row.

Calibration files
-----------------
``calibration_amplitude.csv``
    ``A`` (normalised RF amplitude, 0..1), ``power`` (background-subtracted,
    integrated photodiode signal, arbitrary units; may be slightly negative
    near A=0), optional ``power_err`` (1-sigma of ``power``, same units),
    optional ``run`` and ``timestamp`` (ISO 8601) when one file holds several
    calibration runs.
``calibration_phase.csv``
    ``A``, ``phase_rad`` (optical phase shift, rad; a run spanning more than
    4*pi is refused as degrees), optional ``phase_err`` (rad), ``run``,
    ``timestamp``.

Extra columns are allowed and ignored.
"""

from __future__ import annotations

import difflib
import os
import re

import numpy as np
import pandas as pd

from dpdfit.core.memory import TABLE_BYTES_PER_FILE_BYTE, check_memory
from dpdfit.errors import ImplausibleValueError, InputError, data_line
from dpdfit.recordings.calibration_runs import (CALIBRATION_COLUMNS, CalibrationData,
                                                calibration_data, calibration_runs_data)
from dpdfit.recordings.columns import CAMPAIGN_TABLES
from dpdfit.recordings.csv_text import parse_csv_table
from dpdfit.recordings.input_files import max_input_bytes, read_input_bytes, read_input_chunks
from dpdfit.recordings.outputs import remember_sha256
from dpdfit.recordings.plausibility import check_phase_run_scale, check_phase_span

__all__ = ["read_table", "table_source", "read_calibration", "read_calibration_runs",
           "read_calibration_table", "check_repeated_rows", "read_csv_strings", "require_file",
           "check_calibration_phases", "RANGE_CAUSES"]


def _row(index: int) -> int:
    """1-based data-row number of a 0-based pandas position."""
    return int(index) + 1


def read_table(path: str | os.PathLike, required: list[str],
               optional: list[str] = (), *, numeric: list[str] | None = None,
               ranges: dict[str, tuple[float, float]] | None = None,
               positive: list[str] = (), unique: list[str] = (),
               distinct_rows: bool = False, within=None,
               max_rows: int | None = None) -> pd.DataFrame:
    """Read and validate a CSV file.

    Parameters
    ----------
    path : path-like
        The CSV file (comma separated, one header line; lines starting with
        ``#`` are comments).
    required, optional : list of str
        Column names. Missing required columns raise; a close misspelling is
        suggested.
    numeric : list of str, optional
        Columns that must hold finite numbers (default: all required and
        present optional columns except ``run`` and ``timestamp``); an
        optional column named here is checked when present.
    ranges : dict, optional
        ``{column: (lo, hi)}`` inclusive bounds.
    positive : list of str
        Columns whose values must be strictly positive (uncertainties).
    unique : list of str
        Key columns: no two rows may hold the same combination of their values.
    distinct_rows : bool
        Refuse a row identical in every column to an earlier one (a line
        pasted twice); see :func:`check_repeated_rows`.
    within : path-like, optional
        The folder the file comes from (a campaign folder): the file must lie inside it
        (:func:`read_csv_strings`).
    max_rows : int, optional
        The most data rows the file may hold, counted as it is read: a file with more is
        refused before the rest of it is read (:func:`read_csv_strings`).

    Returns
    -------
    pandas.DataFrame
        With the numeric columns as float64 and, when present, ``timestamp``
        parsed to timezone-aware UTC datetimes and ``run`` as strings.
    """
    name = str(path)
    # a file beyond the input bound is refused for its size by the reader, which says so
    if os.path.isfile(path) and os.path.getsize(path) <= max_input_bytes():
        check_memory(os.path.getsize(path) * TABLE_BYTES_PER_FILE_BYTE, "reading this table",
                     file=name, hint="split the file or set DPDFIT_MAX_MEMORY_GB")
    candidates = (numeric if numeric is not None else
                  [c for c in list(required) + list(optional) if c not in ("run", "timestamp")])
    df = read_csv_strings(path, name, within=within, max_rows=max_rows, numbers=candidates)
    _check_columns(df, required, name)
    present_opt = [c for c in optional if c in df.columns]
    if numeric is None:
        numeric = [c for c in list(required) + present_opt if c not in ("run", "timestamp")]
    out = pd.DataFrame(index=df.index)
    for col in df.columns:
        out[col] = df[col].str.strip() if df[col].dtype == object else df[col]
    for col in numeric:
        if col not in out.columns and col in optional:   # an absent optional column
            continue
        out[col] = _numeric_column(out[col], name, col)
    for col, (lo, hi) in (ranges or {}).items():
        if col in out.columns:
            _check_bounds(out[col], name, col, lo, hi)
    for col in positive:
        if col in out.columns:
            _check_positive(out[col], name, col)
    if unique:
        _check_unique_keys(out, list(unique), name)
    if distinct_rows:
        check_repeated_rows(out, name)
    if "run" in out.columns:
        out["run"] = _run_labels(out["run"], name)
    if "timestamp" in out.columns:
        out["timestamp"] = _timestamps(out["timestamp"], name)
    out.attrs["source"] = name
    return out


def table_source(df) -> str | None:
    """The file a table was read from (``attrs["source"]``, set by the readers); None for a
    table built in Python."""
    return df.attrs.get("source") if hasattr(df, "attrs") else None


def require_file(path: str | os.PathLike) -> str:
    """``str(path)``, or InputError naming it: not found, a directory, not readable."""
    name = str(path)
    if not os.path.exists(path):
        raise InputError("file not found", file=name)
    if os.path.isdir(path):
        raise InputError("is a directory, not a file", file=name)
    if not os.access(path, os.R_OK):
        raise InputError("file is not readable (permission denied)", file=name)
    return name


def read_csv_strings(path, name: str | None = None, *, within=None,
                     max_rows: int | None = None, numbers=()) -> pd.DataFrame:
    """The file as a table of strings, the one place a CSV of recordings is parsed.

    The file is read by :func:`~dpdfit.recordings.input_files.read_input_bytes` (a regular
    file, inside the folder ``within`` when it comes from one -- a campaign folder --, at
    most :func:`~dpdfit.recordings.input_files.max_input_bytes`) and parsed by
    :func:`~dpdfit.recordings.csv_text.parse_csv_strings` (the header and every row checked).
    With ``max_rows``, the rows are counted as the file is read (:func:`_rows_at_most`):
    a file with more is refused before the rest of it is read or anything is parsed.
    InputError naming ``name`` (default the path) when it is absent, empty or not a CSV;
    :class:`~dpdfit.errors.RefusedFileError` when it is not a table a lab writes.
    ``numbers``: columns returned as float64 when each of their cells is a finite number
    (:func:`~dpdfit.recordings.csv_text.parse_csv_table`; strings otherwise)."""
    name = str(path) if name is None else name
    if max_rows is None:
        raw = read_input_bytes(path, within=within, what="file")
    else:
        raw = _rows_at_most(path, name, within, int(max_rows))
    remember_sha256(path, raw)      # read once: parsed and hashed (provenance) from one read
    return parse_csv_table(raw, name, numbers)


#: lines the parser skips (:func:`~dpdfit.recordings.csv_text.parse_csv_strings`): a
#: ``#`` at column 1, or blank
_SKIPPED_LINE = re.compile(rb"^(?:#[^\n]*|[ \t\r\x0b\x0c]*)\n", re.MULTILINE)


def _is_row(line: bytes) -> bool:
    """A line (its break included) the parser does not skip."""
    return not (line.startswith(b"#") or not line.strip())


def _rows_at_most(path, name: str, within, max_rows: int) -> bytes:
    """The bytes of CSV file ``path``, read chunk by chunk
    (:func:`~dpdfit.recordings.input_files.read_input_chunks`) while its lines are
    counted as the parser counts rows (comment and blank lines skipped, the header not a
    row): an InputError naming ``name`` as soon as it holds more than ``max_rows`` rows,
    the rest not read.  A line break inside quotes counts as a row here (a table a lab
    writes, a schedule, has none)."""
    chunks, lines, spanning, first_line = [], 0, [], True
    for chunk in read_input_chunks(path, within=within, what="file"):
        chunks.append(chunk)
        last = chunk.rfind(b"\n") + 1
        if last == 0:                       # a line longer than the chunk goes on
            spanning.append(chunk)
            continue
        first = chunk.find(b"\n") + 1
        # the line begun in earlier chunks (the file's first without its byte-order
        # mark), then the lines wholly in this one
        line = b"".join([*spanning, chunk[:first]])
        if first_line:
            line, first_line = line.removeprefix(b"\xef\xbb\xbf"), False
        lines += _is_row(line)
        whole = chunk[first:last]
        lines += whole.count(b"\n") - len(_SKIPPED_LINE.findall(whole))
        spanning = [chunk[last:]]
        if lines > max_rows + 1:            # the header and max_rows rows
            raise InputError(f"has more than {max_rows} rows, the most dpdfit reads from "
                             "this file (the rest of it was not read)", file=name)
    return b"".join(chunks)


def _check_columns(df: pd.DataFrame, required, name: str) -> None:
    """Every required column (a close misspelling suggested), data rows (the names are
    unique: :func:`read_csv_strings` refuses a name given twice)."""
    for col in required:
        if col not in df.columns:
            close = difflib.get_close_matches(col, df.columns, n=1, cutoff=0.6)
            hint = (f" (found '{close[0]}': misspelt?)" if close
                    else f"; columns present: {list(df.columns)}")
            raise InputError(f"required column is missing{hint}", file=name, column=col)
    if len(df) == 0:
        raise InputError("file has a header but no data rows", file=name)


def _numeric_column(raw: pd.Series, name: str, col: str) -> np.ndarray:
    """The column as finite float64 values (InputError at the first that is not)."""
    vals = pd.to_numeric(raw, errors="coerce")
    bad = vals.isna()
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        text = raw.iloc[i]
        what = "value is empty" if text == "" else (
            "value is NaN" if text.lower() in ("nan", "na", "n/a", "null", "none")
            else f"{_shown(text)} is not a number")
        raise InputError(what, file=name, column=col, row=_row(i))
    arr = vals.to_numpy(dtype=float)
    nonfinite = ~np.isfinite(arr)
    if nonfinite.any():
        i = int(np.flatnonzero(nonfinite)[0])
        raise InputError(f"value is {arr[i]} (must be finite)", file=name, column=col,
                         row=_row(i))
    return arr


def _shown(text) -> str:
    """A cell's text quoted for a one-line message (repr if it holds a line break)."""
    text = str(text)
    return repr(text[:60]) if ("\n" in text or "\r" in text or len(text) > 60) else f"'{text}'"


#: the likely slip behind a value outside its column's documented range
RANGE_CAUSES = {"A": "A is the normalised RF amplitude (1 = maximum diffraction): a "
                     "percentage, a DAC value or dB in its place?"}


def _check_bounds(column: pd.Series, name: str, col: str, lo: float, hi: float) -> None:
    arr = column.to_numpy(dtype=float)
    bad = (arr < lo) | (arr > hi)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        msg = f"value {arr[i]:g} is outside [{lo:g}, {hi:g}]"
        if col in RANGE_CAUSES:
            raise ImplausibleValueError(f"{msg}: {RANGE_CAUSES[col]}", file=name, column=col,
                                        row=_row(i))
        raise InputError(msg, file=name, column=col, row=_row(i))


def _check_unique_keys(df: pd.DataFrame, keys: list[str], name: str) -> None:
    """No two rows with the same values of ``keys`` (InputError at the second one)."""
    dup = df.duplicated(keys, keep="first").to_numpy()
    if dup.any():
        i = int(np.flatnonzero(dup)[0])
        first = int(np.flatnonzero(
            (df[keys] == df[keys].iloc[i]).all(axis=1).to_numpy())[0])
        label = ", ".join(f"{k}={_plain(df[k].iloc[i])}" for k in keys)
        raise InputError(f"{label} repeats {_row_ref(name, first)}: a duplicated line?",
                         file=name, column=keys[-1], row=_row(i))


def check_repeated_rows(df: pd.DataFrame, name: str) -> None:
    """Refuse a row equal in every column to an earlier row: a line pasted twice.

    Only exact copies are refused (numbers compared as numbers, so ``0.5`` and
    ``0.50`` are equal); repeated ``A`` values with different readings are
    legitimate repeated measurements and pass.  ``df``'s positions are the
    data rows of file ``name`` (as :func:`read_table` returns them).
    """
    dup = df.duplicated(keep="first").to_numpy()
    if not dup.any():
        return
    j = int(np.flatnonzero(dup)[0])
    same = (df == df.iloc[j]).all(axis=1).to_numpy()
    i = int(np.flatnonzero(same)[0])
    raise InputError(f"repeats {_row_ref(name, i)} in every column: a line pasted twice?",
                     file=name, row=_row(j))


def _row_ref(name: str, index: int) -> str:
    """``"row 3 (line 5)"``: another row named in a message, with its line when known."""
    line = data_line(name, _row(index))
    return f"row {_row(index)}" + (f" (line {line})" if line is not None else "")


def _plain(value) -> str:
    """A table value as plain text (``0.5``, not ``np.float64(0.5)``)."""
    if isinstance(value, (float, np.floating)):
        return f"{float(value):g}"
    if isinstance(value, (np.integer,)):
        return str(int(value))
    return str(value)


def _check_positive(column: pd.Series, name: str, col: str) -> None:
    arr = column.to_numpy(dtype=float)
    bad = arr <= 0
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"uncertainty {arr[i]:g} must be > 0", file=name, column=col,
                         row=_row(i))


def _run_labels(column: pd.Series, name: str) -> pd.Series:
    """Run labels as non-empty strings."""
    runs = column.astype(str)
    empty = runs == ""
    if empty.any():
        i = int(np.flatnonzero(empty.to_numpy())[0])
        raise InputError("run label is empty", file=name, column="run", row=_row(i))
    return runs


def _timestamps(column: pd.Series, name: str) -> pd.Series:
    """ISO 8601 date/times parsed to timezone-aware UTC."""
    ts = pd.to_datetime(column, errors="coerce", utc=True, format="mixed")
    bad = ts.isna()
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        raise InputError(f"{_shown(column.iloc[i])} is not a date/time (use ISO 8601, "
                         "e.g. 2026-03-01T09:30:00)", file=name, column="timestamp",
                         row=_row(i))
    return ts


def _calibration_table(path: str | os.PathLike, kind: str, within=None
                       ) -> tuple[pd.DataFrame, str, str]:
    """The whole calibration file, validated, and its value and error columns."""
    value_col, err_col = CALIBRATION_COLUMNS[kind]
    required, optional = CAMPAIGN_TABLES[f"calibration_{kind}"]
    df = read_table(path, list(required), list(optional),
                    ranges={"A": (0.0, 1.0)}, positive=[err_col], distinct_rows=True,
                    within=within)
    if kind == "phase":
        check_calibration_phases(df, str(path))
    return df, value_col, err_col


def check_calibration_phases(df: pd.DataFrame, name: str) -> None:
    """Refuse a phase calibration whose ``phase_rad`` spans degrees within a run
    (:func:`~dpdfit.recordings.plausibility.check_phase_span`; the whole file without
    a ``run`` column), or one of whose runs is in degrees among runs in radians
    (:func:`~dpdfit.recordings.plausibility.check_phase_run_scale`)."""
    keys = ["run"] if "run" in df.columns else []
    check_phase_span(df, "phase_rad", keys, name,
                     lambda k: f"run {k[0]}" if k else "the calibration")
    check_phase_run_scale(df, "phase_rad", name)


def read_calibration_table(path: str | os.PathLike, kind: str, *, within=None
                           ) -> pd.DataFrame:
    """A whole calibration file (every run), validated once (``attrs["source"]``: path);
    ``within``: the folder it must lie in (:func:`read_csv_strings`)."""
    df, _, _ = _calibration_table(path, kind, within)
    df.attrs["source"] = str(path)
    return df


def read_calibration(path: str | os.PathLike, kind: str, run: str | None = None
                     ) -> CalibrationData:
    """Read one run of an amplitude or phase calibration file.

    Parameters
    ----------
    path : path-like
        CSV file (see module docstring for the columns).
    kind : {"amplitude", "phase"}
    run : str, optional
        Run label, or ``"latest"``; required if the file holds several runs.
    """
    return calibration_data(read_calibration_table(path, kind), kind, run)


def read_calibration_runs(path: str | os.PathLike, kind: str) -> dict:
    """Every run of a calibration file, ``{label: CalibrationData}`` in file order.

    The same data as :func:`read_calibration` per run (label ``None`` for a
    file without a ``run`` column), but the file is read and validated once:
    linear, not quadratic, in the number of runs.
    """
    return calibration_runs_data(read_calibration_table(path, kind), kind)