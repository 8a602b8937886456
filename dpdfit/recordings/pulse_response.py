"""``pulse_response.csv``: the lab's AOM pulse response, a fast photodiode trace of an RF
step.

The experiment shows the modulator's memory directly: a drive switched from 0 to ``A``
gives a diffracted power that rises with the acoustic response (nanoseconds) and then
follows the crystal's slow gain change (microseconds).  The spectra see the same memory
only through intermodulation products, where it looks like a higher-order nonlinearity.
One row per sample of a trace: ``t_us`` (time from the RF step, us; a pre-trigger sample
is negative), ``power`` (the fast photodiode's reading, the lab's own unit, a scope
trace averaged over many steps); optional ``A`` (the step's drive amplitude, normalised
as everywhere; absent: the campaign's gate amplitude, ``default_A``), ``power_err`` (its
1-sigma, same unit), ``run`` and ``timestamp`` (labels).

A *step* is one trace: the rows of one ``A`` (and ``run``) in file order; a trace
recorded again (appended by ``dpdfit add``) starts a further step where its time goes
back to or before the first time of the step before.  :func:`read_pulse_response` checks
every row (one :class:`~dpdfit.errors.InputError` naming the file, the column and the
data row): a table without a time axis, times that do not increase within a step, a
negative reading (a photodiode reads no less than no light), a time no trace in
microseconds holds (:data:`MAX_PULSE_TIME_US`: a unit slip).
"""

from __future__ import annotations

import os

import numpy as np
import pandas as pd

from dpdfit.errors import ImplausibleValueError, InputError

from .columns import CAMPAIGN_TABLES, MISSING_LINES, header_columns
from .tables import read_table

__all__ = ["read_pulse_response", "MAX_PULSE_TIME_US", "step_labels"]

#: the largest time from the step (us) a trace may hold: an AOM's memory is the acoustic
#: response (tens to hundreds of ns) and the crystal's thermal gain change (0.3 to 10 us
#: in labs' traces; the diagnosis bounds its time scales at 50 us), so a trace of 20 time
#: constants ends well within 1 ms, while a 10-us trace written in ns reaches 1e4
MAX_PULSE_TIME_US = 1000.0


def _check_time_axis(path, name: str, within) -> None:
    """The header has ``t_us`` (the time axis), else one line saying so."""
    try:
        have = header_columns(path, within=within)
    except InputError:
        return                        # read_table names what is wrong with the file
    if "t_us" not in have:
        raise InputError(MISSING_LINES[("pulse_response", "t_us")], file=name)


def step_labels(df: pd.DataFrame) -> np.ndarray:
    """The step (0, 1, ...) of each row: a new one where ``A`` or ``run`` changes, or
    where the time goes back to or before the current step's first time (a trace
    recorded again).  A time that goes back less far is left in its step (and refused
    there by :func:`read_pulse_response`)."""
    t = df["t_us"].to_numpy(dtype=float)
    n = t.size
    new = np.zeros(n, dtype=bool)
    new[0] = True
    for col in ("A", "run"):
        if col in df.columns:
            v = df[col].to_numpy()
            new[1:] |= v[1:] != v[:-1]
    start = 0
    for i in np.flatnonzero(np.r_[False, t[1:] <= t[:-1]] | new):
        if new[i] or t[i] <= t[start]:
            new[i], start = True, i
    return np.cumsum(new) - 1


def _check_times(df: pd.DataFrame, steps: np.ndarray, name: str) -> None:
    """Times increase within every step; every time is plausible in us."""
    t = df["t_us"].to_numpy(dtype=float)
    far = np.abs(t) > MAX_PULSE_TIME_US
    if far.any():
        i = int(np.flatnonzero(far)[0])
        raise ImplausibleValueError(
            f"time {t[i]:g} us from the RF step is beyond {MAX_PULSE_TIME_US:g} us, longer "
            "than any AOM's memory: written in ns (or another unit) under t_us?",
            file=name, column="t_us", row=i + 1)
    back = np.r_[False, (t[1:] <= t[:-1]) & (steps[1:] == steps[:-1])]
    if back.any():
        i = int(np.flatnonzero(back)[0])
        raise InputError(f"time {t[i]:g} us does not increase within its step (the row "
                         f"before reads {t[i - 1]:g} us): rows out of order, or two traces "
                         "interleaved?", file=name, column="t_us", row=i + 1)


def read_pulse_response(path: str | os.PathLike, *, within=None,
                        default_A: float | None = None) -> pd.DataFrame:
    """Read and validate a pulse-response file ``t_us, power`` (+ ``A``, ``power_err``,
    ``run``, ``timestamp``).

    ``default_A``: the drive amplitude of a file without ``A`` (the campaign's gate
    amplitude); without one such a file is refused.  ``within``: the folder the file
    must lie in (:func:`~dpdfit.recordings.tables.read_csv_strings`).

    Returns
    -------
    pandas.DataFrame
        The rows in file order (the index is the 0-based data row): ``t_us``, ``power``,
        ``A`` (float64; ``default_A`` where the file has none), ``power_err`` when given,
        the labels, and ``step`` (:func:`step_labels`).
    """
    name = str(path)
    _check_time_axis(path, name, within)
    required, optional = (list(c) for c in CAMPAIGN_TABLES["pulse_response"])
    df = read_table(path, required, optional, ranges={"A": (0.0, 1.0)},
                    positive=["power_err"], within=within)
    bad = (df["power"] < 0).to_numpy()
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"negative reading {df['power'].iloc[i]:g}: a photodiode reads no "
                         "less than no light (a background subtracted twice, or a sign "
                         "flipped?)", file=name, column="power", row=i + 1)
    if "A" not in df.columns:
        if default_A is None:
            raise InputError("no drive amplitude: the file has no column A and the campaign "
                             "no single gate amplitude (time_scans.csv's A) to take",
                             file=name, column="A")
        df["A"] = float(default_A)
    steps = step_labels(df)
    _check_times(df, steps, name)
    df["step"] = steps
    df.attrs["source"] = name
    return df
