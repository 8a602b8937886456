"""Recordings -> validated tables.

Every CSV that enters dpdfit passes through :func:`read_table`, which checks
it once and completely, so that the fitting code never sees a malformed value.
A problem is reported as one :class:`~dpdfit.errors.InputError` line naming the
file, the column and the data row (row 1 is the first line after the header,
i.e. line 2 of the file).

Calibration files
-----------------
``calibration_amplitude.csv``
    ``A`` (normalised RF amplitude, 0..1), ``power`` (background-subtracted,
    integrated photodiode signal, arbitrary units; may be slightly negative
    near A=0), optional ``power_err`` (1-sigma of ``power``, same units),
    optional ``run`` and ``timestamp`` (ISO 8601) when one file holds several
    calibration runs.
``calibration_phase.csv``
    ``A``, ``phase_rad`` (optical phase shift, rad), optional ``phase_err``
    (rad), ``run``, ``timestamp``.

Extra columns are allowed and ignored.
"""

from __future__ import annotations

import difflib
import os
from dataclasses import dataclass

import numpy as np
import pandas as pd

from dpdfit.errors import InputError

__all__ = ["read_table", "CalibrationData", "read_calibration", "select_run",
           "list_runs", "check_duplicates"]


def _row(index: int) -> int:
    """1-based data-row number of a 0-based pandas position."""
    return int(index) + 1


def read_table(path: str | os.PathLike, required: list[str],
               optional: list[str] = (), *, numeric: list[str] | None = None,
               ranges: dict[str, tuple[float, float]] | None = None,
               positive: list[str] = (), unique: list[str] = ()) -> pd.DataFrame:
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
        present optional columns except ``run`` and ``timestamp``).
    ranges : dict, optional
        ``{column: (lo, hi)}`` inclusive bounds.
    positive : list of str
        Columns whose values must be strictly positive (uncertainties).
    unique : list of str
        Key columns: no two rows may hold the same combination of their values.

    Returns
    -------
    pandas.DataFrame
        With the numeric columns as float64 and, when present, ``timestamp``
        parsed to timezone-aware UTC datetimes and ``run`` as strings.
    """
    name = str(path)
    df = _read_csv(path, name)
    _check_columns(df, required, name)
    present_opt = [c for c in optional if c in df.columns]
    if numeric is None:
        numeric = [c for c in list(required) + present_opt if c not in ("run", "timestamp")]
    out = pd.DataFrame(index=df.index)
    for col in df.columns:
        out[col] = df[col].str.strip() if df[col].dtype == object else df[col]
    for col in numeric:
        out[col] = _numeric_column(out[col], name, col)
    for col, (lo, hi) in (ranges or {}).items():
        if col in out.columns:
            _check_bounds(out[col], name, col, lo, hi)
    for col in positive:
        if col in out.columns:
            _check_positive(out[col], name, col)
    if unique:
        _check_unique_keys(out, list(unique), name)
    if "run" in out.columns:
        out["run"] = _run_labels(out["run"], name)
    if "timestamp" in out.columns:
        out["timestamp"] = _timestamps(out["timestamp"], name)
    out.attrs["source"] = name
    return out


def _read_csv(path, name: str) -> pd.DataFrame:
    """The file as a table of strings (InputError when absent, empty or not a CSV)."""
    if not os.path.exists(path):
        raise InputError("file not found", file=name)
    try:
        df = pd.read_csv(path, comment="#", skipinitialspace=True, dtype=str,
                         keep_default_na=False)
    except pd.errors.EmptyDataError:
        raise InputError("file is empty (no header, no data)", file=name) from None
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        msg = str(exc).strip().splitlines()[-1] if str(exc).strip() else type(exc).__name__
        raise InputError(f"not a readable CSV file ({msg})", file=name) from None
    df.columns = [str(c).strip() for c in df.columns]
    return df


def _check_columns(df: pd.DataFrame, required, name: str) -> None:
    """Unique column names, every required column (a close misspelling suggested), data rows."""
    dupes = {c for c in df.columns if list(df.columns).count(c) > 1}
    if dupes:
        raise InputError(f"column name(s) appear more than once: {sorted(dupes)}", file=name)
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


def _check_bounds(column: pd.Series, name: str, col: str, lo: float, hi: float) -> None:
    arr = column.to_numpy(dtype=float)
    bad = (arr < lo) | (arr > hi)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"value {arr[i]:g} is outside [{lo:g}, {hi:g}]", file=name,
                         column=col, row=_row(i))


def _check_unique_keys(df: pd.DataFrame, keys: list[str], name: str) -> None:
    """No two rows with the same values of ``keys`` (InputError at the second one)."""
    dup = df.duplicated(keys, keep="first").to_numpy()
    if dup.any():
        i = int(np.flatnonzero(dup)[0])
        first = int(np.flatnonzero(
            (df[keys] == df[keys].iloc[i]).all(axis=1).to_numpy())[0])
        label = ", ".join(f"{k}={_plain(df[k].iloc[i])}" for k in keys)
        raise InputError(f"{label} repeats row {_row(first)}: a duplicated line?",
                         file=name, column=keys[-1], row=_row(i))


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


@dataclass(frozen=True)
class CalibrationData:
    """One calibration run's points, validated.

    Attributes
    ----------
    A : ndarray
        Normalised RF amplitudes (0..1).
    value : ndarray
        ``power`` (arbitrary units) or ``phase_rad`` (rad).
    error : ndarray or None
        1-sigma uncertainties of ``value`` if the file has them.
    rows : ndarray of int
        1-based data-row numbers in the source file (for messages).
    source : str
        File name. ``run`` and ``timestamp`` (ISO string) identify the run.
    """

    A: np.ndarray
    value: np.ndarray
    error: np.ndarray | None
    rows: np.ndarray
    source: str
    run: str | None = None
    timestamp: str | None = None


def list_runs(df: pd.DataFrame) -> list[str]:
    """Run labels in order of first appearance (``[]`` if no ``run`` column)."""
    if "run" not in df.columns:
        return []
    return list(dict.fromkeys(df["run"].tolist()))


def select_run(df: pd.DataFrame, run: str | None) -> tuple[pd.DataFrame, str | None]:
    """Rows of one run.

    ``run=None`` is allowed only when the table holds a single run;
    ``run="latest"`` picks the run with the latest timestamp (or the last in
    the file without timestamps).
    """
    name = df.attrs.get("source")
    runs = list_runs(df)
    if not runs:
        if run not in (None, "latest"):
            raise InputError(f"--run {run} given but the file has no 'run' column", file=name)
        return df, None
    if run is None:
        if len(runs) == 1:
            return df, runs[0]
        shown = ", ".join(runs[:8]) + (" ..." if len(runs) > 8 else "")
        raise InputError(f"file holds {len(runs)} runs ({shown}); choose one with --run ID, "
                         "--run latest, or fit each with --all-runs", file=name)
    if run == "latest":
        if "timestamp" in df.columns:
            last = df.groupby("run", sort=False)["timestamp"].min().idxmax()
        else:
            last = runs[-1]
        run = last
    if str(run) not in runs:
        raise InputError(f"run '{run}' not found; runs present: {', '.join(runs[:20])}",
                         file=name, column="run")
    return df[df["run"] == str(run)], str(run)


def check_duplicates(A: np.ndarray, value: np.ndarray, error: np.ndarray | None,
                     rows: np.ndarray, *, file: str, column: str,
                     noise_scale: float | None = None, z_max: float = 6.0) -> None:
    """Refuse repeated amplitudes whose values contradict each other.

    Repeated measurements at the same ``A`` are legitimate and kept.  They
    contradict each other when their spread is inconsistent with the noise:
    the largest deviation from the group's weighted mean exceeds ``z_max``
    standard deviations (``error`` if given, else ``noise_scale``, a robust
    estimate of the per-point scatter supplied by the caller).  ``z_max = 6``
    makes a false alarm on honest Gaussian data practically impossible
    (two-sided p ~ 2e-9 per pair).
    """
    order = np.argsort(A, kind="stable")
    As = A[order]
    same = np.flatnonzero(np.diff(As) == 0)
    if same.size == 0:
        return
    starts = np.unique(np.searchsorted(As, As[same], side="left"))
    for s in starts:
        idx = order[s:np.searchsorted(As, As[s], side="right")]
        v = value[idx]
        if error is not None:
            sig = error[idx]
        elif noise_scale is not None and noise_scale > 0:
            sig = np.full(v.shape, noise_scale)
        else:
            continue  # no noise scale to judge by; the fit's chi-square will tell
        w = 1 / sig**2
        mean = np.sum(w * v) / np.sum(w)
        z = np.abs(v - mean) / sig * np.sqrt(len(v) / max(len(v) - 1, 1))
        if z.max() > z_max:
            r = sorted(int(x) for x in rows[idx])
            raise InputError(
                f"duplicate A={As[s]:g} with contradicting values "
                f"({', '.join(f'{x:.6g}' for x in v)}; {z.max():.1f} sigma apart) in rows "
                f"{', '.join(map(str, r))}", file=file, column=column, row=r[0])


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
    value_col, err_col = {"amplitude": ("power", "power_err"),
                          "phase": ("phase_rad", "phase_err")}[kind]
    df = read_table(path, ["A", value_col], [err_col, "run", "timestamp"],
                    ranges={"A": (0.0, 1.0)}, positive=[err_col])
    sub, label = select_run(df, run)
    rows = sub.index.to_numpy() + 1
    ts = None
    if "timestamp" in sub.columns:
        ts = sub["timestamp"].min().isoformat()
    return CalibrationData(
        A=sub["A"].to_numpy(dtype=float), value=sub[value_col].to_numpy(dtype=float),
        error=sub[err_col].to_numpy(dtype=float) if err_col in sub.columns else None,
        rows=rows, source=str(path), run=label, timestamp=ts)
