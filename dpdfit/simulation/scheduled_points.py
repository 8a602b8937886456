"""Did the stand-in record what the schedule asks?  Every scheduled point, as scheduled.

The simulator standing in for the lab (:func:`~dpdfit.simulation.recorded_artiq.record_schedule`)
records a schedule through its measurements (:func:`~dpdfit.simulation.further_recordings.schedule_measurements`):
a calibration run on the simulator's own amplitude grid, a time scan at its own times,
a parity scan at its analysis phases.  A schedule made from a proposal asks exactly
those (they are the campaign's own).  One edited to other points cannot be recorded
as written, and :func:`check_recorded_as_scheduled` refuses it in one line naming the
first point that was not recorded, instead of recording something else silently.

A recording may hold more rows than its schedule (a scan at a new setting also records
its gate rate and, for a parity scan, its populations): each scheduled point must be
among the recorded rows, as many times as it is scheduled.
"""

from __future__ import annotations

from collections import Counter

import numpy as np
import pandas as pd

from dpdfit.errors import InputError

__all__ = ["check_recorded_as_scheduled"]

#: kind -> (recorded table, schedule column -> table column) of a point's identity
_POINTS = {
    "amplitude_run": ("calibration_amplitude", {"A": "A"}),
    "phase_run": ("calibration_phase", {"A": "A"}),
    "spectra": ("spectra", {"A": "A", "dpd": "dpd"}),
    "populations": ("populations", {"A": "A", "dpd": "dpd", "shots": "shots"}),
    "parity": ("parity", {"A": "A", "dpd": "dpd", "phase_rad": "phase_rad",
                          "shots": "shots"}),
    "time_scan": ("time_scans", {"A": "A", "dpd": "dpd", "t_us": "t_us", "shots": "shots"}),
    # the prepared state as a number (00 -> 0, 01 -> 1, 10 -> 10, 11 -> 11): distinct
    "spam": ("spam", {"prepared": "prepared", "shots": "shots"}),
    # a pulse response is one point per trace: its step's amplitude
    "pulse_response": ("pulse_response", {"A": "A"}),
    # both sequences share the waits: the point is its wait, recorded once per sequence
    "ramsey": ("ramsey", {"wait_us": "wait_us", "shots": "shots"}),
    "detector_linearity": ("detector_linearity", {"A": "A",
                                                  "attenuation_db": "attenuation_db"}),
    # the sideband as a number (red -> 0, blue -> 1)
    "thermometry": ("thermometry", {"wait_us": "wait_us", "sideband": "sideband",
                                    "shots": "shots"}),
}
#: text columns of a point's identity, as numbers
_CODES = {"sideband": {"red": 0.0, "blue": 1.0}}


def _numbers(frame: pd.DataFrame) -> np.ndarray:
    """The columns of ``frame`` as floats, the text ones of :data:`_CODES` coded."""
    frame = frame.copy()
    for col, codes in _CODES.items():
        if col in frame.columns:
            frame[col] = frame[col].astype(str).str.strip().str.lower().map(codes)
    return frame.to_numpy(float)


#: significant digits a point's values must share (the campaign's CSVs keep 10)
_DIGITS = 8


def _key(values) -> tuple:
    return tuple(float(f"{float(v):.{_DIGITS}g}") for v in values)


def _recorded(table: pd.DataFrame | None, columns: list, kind: str) -> Counter:
    if table is None or not len(table):
        return Counter()
    if kind == "spectra":
        # a trace is one reading of every tone at its (A, dpd): count traces, not tones
        traces = table.groupby(["A", "dpd", "sideband", "n"]).size().groupby(
            level=["A", "dpd"]).max()
        return Counter({_key(k): int(v) for k, v in traces.items()})
    if kind == "pulse_response":
        # a trace is its run's samples: count traces, not samples
        traces = table.drop_duplicates(["run", "A"])[["A"]].to_numpy(float)
        return Counter(_key(r) for r in traces)
    return Counter(_key(r) for r in _numbers(table[columns]))


def check_recorded_as_scheduled(schedule: pd.DataFrame, tables: dict,
                                name: str = "schedule") -> None:
    """InputError naming the first scheduled point the recording ``tables`` (table name ->
    the new rows) does not hold (module doc); ``name``: the schedule file named."""
    for kind, rows in schedule.groupby("kind", sort=False):
        table, cols = _POINTS[kind]
        have = _recorded(tables.get(table), list(cols.values()), kind)
        want = _numbers(rows[list(cols)])
        for idx, values in zip(rows.index, want):
            k = _key(values)
            if have[k] > 0:
                have[k] -= 1
                continue
            what = ", ".join(f"{c} = {v:g}" for c, v in zip(cols, values)
                             if np.isfinite(v))
            raise InputError(
                f"the simulator standing in for the lab cannot record this {kind} point "
                f"({what}) as scheduled: it records the points the campaign's own "
                f"recordings repeat (the schedule dpdfit diagnose --schedule writes)",
                file=name, row=int(idx) + 1)
