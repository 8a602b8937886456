"""Calibration runs as data: one run's points (:class:`CalibrationData`) and the runs of a
calibration table already read.

:func:`calibration_data` and :func:`calibration_runs_data` split a validated
calibration table (:func:`dpdfit.recordings.tables.read_calibration_table`, or
the campaign folder's cached table) into runs without opening the file again;
:func:`select_run` picks one run by label or ``"latest"``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from dpdfit.errors import InputError

__all__ = ["CalibrationData", "list_runs", "select_run", "calibration_data",
           "calibration_runs_data", "CALIBRATION_COLUMNS"]


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


#: kind -> (value column, error column) of a calibration file
CALIBRATION_COLUMNS = {"amplitude": ("power", "power_err"), "phase": ("phase_rad", "phase_err")}


def _calibration_data(sub: pd.DataFrame, label, path, value_col: str, err_col: str
                      ) -> CalibrationData:
    """One run's rows (``sub``, indexed by file position) as :class:`CalibrationData`."""
    ts = None
    if "timestamp" in sub.columns:
        ts = sub["timestamp"].min().isoformat()
    return CalibrationData(
        A=sub["A"].to_numpy(dtype=float), value=sub[value_col].to_numpy(dtype=float),
        error=sub[err_col].to_numpy(dtype=float) if err_col in sub.columns else None,
        rows=sub.index.to_numpy() + 1, source=str(path), run=label, timestamp=ts)


def calibration_data(df: pd.DataFrame, kind: str, run: str | None = None
                     ) -> CalibrationData:
    """One run of a calibration table already read (:func:`read_table` with the columns
    of :func:`read_calibration`): the same data, without opening the file again."""
    value_col, err_col = CALIBRATION_COLUMNS[kind]
    sub, label = select_run(df, run)
    return _calibration_data(sub, label, df.attrs.get("source"), value_col, err_col)


def calibration_runs_data(df: pd.DataFrame, kind: str) -> dict:
    """Every run of a calibration table already read, ``{label: CalibrationData}`` in
    table order (label ``None`` for a table without a ``run`` column)."""
    value_col, err_col = CALIBRATION_COLUMNS[kind]
    path = df.attrs.get("source")
    if not list_runs(df):
        return {None: _calibration_data(df, None, path, value_col, err_col)}
    groups = df.groupby("run", sort=False).indices
    return {str(r): _calibration_data(df.iloc[pos], str(r), path, value_col, err_col)
            for r, pos in groups.items()}
