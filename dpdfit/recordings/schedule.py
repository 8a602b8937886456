"""The schedule file: a proposed recording as the list of points a lab records.

One row per point and repeat, plain enough that an ARTIQ experiment loops over it
(the documentation's page "Deciding with one more recording" shows one).  Columns:

``kind``
    What is recorded: ``amplitude_run``, ``phase_run``, ``spectra``, ``populations``,
    ``parity``, ``time_scan``, ``spam``, ``pulse_response``, ``ramsey`` or
    ``detector_linearity`` (the diagnosis's
    ``next_measurement.what``).
``repeat``
    Which repeat (run, scan, trace) the row belongs to: 1, 2, ...
``point``
    The point within its repeat: 0, 1, ... (the order to record them in).
``A``
    The amplitude of the point: a grid point of a calibration run, the amplitude of a
    trace, the gate setting of a scan (normalised RF amplitude, 0..1); 0 for a SPAM or
    Ramsey point (no gate is driven); the step's amplitude of a pulse response (one point
    per trace: the drive switched from 0 to ``A``, traced by a fast photodiode); the
    drive of a detector linearity point.
``dpd``
    0 or 1 (with or without predistortion); empty for calibration runs, SPAM, Ramsey and
    detector linearity points and pulse responses.
``shots``
    Shots of the point: of the population scan, of one phase of a parity scan, of one
    time of a time scan, of one prepared state of a SPAM characterisation, of one
    sequence and wait of a Ramsey scan; empty for calibration runs, spectra, pulse
    responses and detector linearity points.
``phase_rad``
    The analysis phase of a parity point (rad); empty otherwise.
``t_us``
    The gate time of a time-scan point (microseconds); empty otherwise.
``lab_s``
    The row's own lab time (seconds), as the diagnosis counted it
    (:class:`~dpdfit.core.defaults.LabTimes`): ``shots`` times ``shot_s`` for a scan
    point (``spam_shot_s`` for a SPAM state; ``ramsey_shot_s`` plus the wait per shot and
    ``ramsey_point_s`` for a Ramsey point), ``spectrum_trace_s`` for a trace
    (``pulse_trace_s`` for a pulse response), the run's
    time over its grid points for a calibration-run point.  The column sums to the
    proposal's ``lab_seconds`` (rescaled to it when the proposal was made with other lab
    times).  The waits between paced calibration runs are not lab time.
``day``
    The day of the row's session (integer): 0 is the next session, which the proposal
    predicts as if it were the day of the campaign's latest recording ("now"); a
    calibration run paced days after the previous one has a later day.
``start_s``
    When the row is taken (seconds from the start of its day's session): rows taken back
    to back follow each other by their ``lab_s``; a paced calibration run starts its
    spacing after the previous run's start.
``tone_sd_db``
    Spectra only: the repeatability of a tone's power between traces (dB, 1 sigma) the
    diagnosis learnt from the campaign's spectra and assumed for each trace (one row is
    one trace, captured as the campaign's traces were); empty otherwise.
``prepared``
    Only in a schedule with ``spam`` rows (the other schedules keep the columns above):
    the basis state a SPAM point prepares, ``00``, ``01``, ``10`` or ``11`` (as
    ``spam.csv`` records it); empty for the other kinds.
``sequence``, ``wait_us``
    Only in a schedule with ``ramsey`` rows (after the others): the sequence of a Ramsey
    point, ``ramsey`` or ``echo``, and its free-precession wait (microseconds), as
    ``ramsey.csv`` records them; empty for the other kinds.
``attenuation_db``
    Only in a schedule with ``detector_linearity`` rows (after the columns above): the
    calibrated attenuator (dB, > 0) the photodiode is read with at the point's drive,
    after its reading without; empty for the other kinds.  Such a point's ``lab_s`` is
    its two readings and its share of putting the attenuator in.
``wait_us``, ``sideband``
    Only in a schedule with ``thermometry`` rows: the wait after cooling before the probe
    (us, at least 0) and the sideband probed (``red`` or ``blue``) of a
    sideband-thermometry point, as ``thermometry.csv`` records them; empty for the other
    kinds.  ``wait_us`` is the one column the Ramsey rows fill too (after ``sequence``,
    where a schedule with ``ramsey`` rows has it); ``sideband`` comes last.

The columns ``day``, ``start_s`` and ``tone_sd_db`` came later and are optional: a
schedule without them is read with them empty.  Rows of every kind are taken back to
back, except calibration runs, which are paced
(:mod:`dpdfit.analyses.diagnosis.proposal.schedule`).

:func:`read_schedule` checks a schedule file (one :class:`~dpdfit.errors.InputError`
line naming the file, column and row for anything that cannot be recorded);
:func:`write_schedule` writes one atomically.
"""

from __future__ import annotations

import os

import numpy as np
import pandas as pd

from dpdfit.core.defaults import MAX_SCHEDULE_ROWS
from dpdfit.errors import InputError
from dpdfit.recordings.outputs import atomic_write_text, csv_table_text
from dpdfit.recordings.tables import read_table

__all__ = ["SCHEDULE_COLUMNS", "OPTIONAL_COLUMNS", "SCHEDULE_KINDS", "RUN_KINDS",
           "SCAN_KINDS", "CHARACTERISATION_KINDS", "read_schedule", "write_schedule",
           "check_schedule", "LINEARITY_KINDS", "LINEARITY_COLUMN"]

#: the schedule's columns, in order (a contract: labs' experiments read them by name)
SCHEDULE_COLUMNS = ("kind", "repeat", "point", "A", "dpd", "shots", "phase_rad", "t_us",
                    "lab_s", "day", "start_s", "tone_sd_db")
#: the columns a schedule file may leave out (read back empty): all but the first four
OPTIONAL_COLUMNS = SCHEDULE_COLUMNS[4:]
#: calibration runs: a grid of amplitudes, no flag, no shots
RUN_KINDS = ("amplitude_run", "phase_run")
#: gate recordings: a setting (A, dpd) and shots per point
SCAN_KINDS = ("populations", "parity", "time_scan")
#: the lab's characterisation experiments: no flag; a SPAM, Ramsey or thermometry point
#: has no gate setting (``A`` 0) and shots, a pulse response the step's amplitude ``A``
#: and no shots, a detector linearity point a drive ``A`` (as a calibration run's grid
#: point), no shots and an attenuator (:data:`LINEARITY_COLUMN`)
CHARACTERISATION_KINDS = ("spam", "pulse_response", "ramsey", "detector_linearity",
                          "thermometry")
#: the characterisation kinds that drive no gate (``A`` 0)
_UNGATED = ("spam", "ramsey", "thermometry")
#: the detector linearity characterisation: a drive (``A``, no flag, no shots) read
#: without and with an attenuator (:data:`LINEARITY_COLUMN`)
LINEARITY_KINDS = ("detector_linearity",)
#: the column a schedule has only when it holds ``detector_linearity`` rows
LINEARITY_COLUMN = "attenuation_db"
#: every kind of recording a schedule may hold (the diagnosis's menu)
SCHEDULE_KINDS = RUN_KINDS + ("spectra",) + SCAN_KINDS + CHARACTERISATION_KINDS
#: the column a schedule has only when it holds ``spam`` rows (after the others)
_PREPARED = "prepared"
_BASIS_STATES = ("00", "01", "10", "11")
#: the columns a schedule has only when it holds ``ramsey`` rows (after the others)
_RAMSEY = ("sequence", "wait_us")
_SEQUENCES = ("ramsey", "echo")
#: the columns a schedule has only when it holds ``thermometry`` rows (after the others)
_THERMOMETRY = ("wait_us", "sideband")
_SIDEBANDS = ("red", "blue")
#: the kinds whose rows fill ``wait_us`` (Ramsey and thermometry share the column)
_WAITED = ("ramsey", "thermometry")
#: per kind, the columns its rows must fill (besides kind, repeat, point, A)
_NEEDS = {"amplitude_run": (), "phase_run": (), "spectra": ("dpd",),
          "populations": ("dpd", "shots"), "parity": ("dpd", "shots", "phase_rad"),
          "time_scan": ("dpd", "shots", "t_us"), "spam": ("shots",), "pulse_response": (),
          "ramsey": ("shots", "wait_us"), "detector_linearity": (),
          "thermometry": ("shots", "wait_us")}
#: per kind, the columns that must not change within one repeat
_CONSTANT = {"populations": ("A", "dpd", "shots"), "parity": ("A", "dpd", "shots"),
             "time_scan": ("A", "dpd", "shots")}


def _fail(msg: str, name: str, col: str | None = None, i: int | None = None):
    raise InputError(msg, file=name, column=col, row=None if i is None else int(i) + 1)


def _integers(df: pd.DataFrame, col: str, rows: np.ndarray, least: int, name: str) -> None:
    v = df[col].to_numpy(float)
    bad = np.flatnonzero(rows & ~((v == np.round(v)) & (v >= least)))
    if bad.size:
        _fail(f"{df[col].iloc[bad[0]]!r} must be an integer >= {least}", name, col, bad[0])


def _filled(df: pd.DataFrame, col: str, rows: np.ndarray, kind: str, name: str) -> None:
    """``col`` of the ``kind`` rows: present and a finite number."""
    if col not in df.columns:
        if rows.any():
            _fail(f"column '{col}' is missing (the '{kind}' rows need it)", name)
        return
    v = pd.to_numeric(df[col], errors="coerce").to_numpy(float)
    bad = np.flatnonzero(rows & ~np.isfinite(v))
    if bad.size:
        _fail(f"{df[col].iloc[bad[0]]!r}: a '{kind}' row needs a number here", name, col,
              bad[0])
    df[col] = v


def _numbers(cells: pd.Series, col: str, name: str) -> pd.Series:
    """An optional column as numbers, an empty cell as NaN; text that is not a number is
    refused (it would otherwise read as empty and be recorded as if left out)."""
    v = pd.to_numeric(cells, errors="coerce")
    text = cells.astype(str).str.strip().str.lower()
    bad = np.flatnonzero((v.isna() & cells.notna() & ~text.isin(("", "nan", "<na>")))
                         .to_numpy())
    if bad.size:
        _fail(f"{cells.iloc[bad[0]]!r} is not a number", name, col, bad[0])
    return v


def check_schedule(df: pd.DataFrame, name: str = "schedule") -> pd.DataFrame:
    """A schedule table checked (module doc) and typed: the numeric columns as float64,
    ``kind`` as text.  ``name`` is the file named in an error line."""
    df = df.copy()
    if len(df) > MAX_SCHEDULE_ROWS:
        _fail(f"{len(df)} rows: more than a schedule can hold ({MAX_SCHEDULE_ROWS})", name)
    kind = df["kind"].astype(str).str.strip()
    unknown = np.flatnonzero(~kind.isin(SCHEDULE_KINDS).to_numpy())
    if unknown.size:
        _fail(f"unknown kind {kind.iloc[unknown[0]]!r} (known: {', '.join(SCHEDULE_KINDS)})",
              name, "kind", unknown[0])
    df["kind"] = kind
    every = np.ones(len(df), bool)
    _integers(df, "repeat", every, 1, name)
    _integers(df, "point", every, 0, name)
    for k, cols in _NEEDS.items():
        rows = (kind == k).to_numpy()
        for col in cols:
            _filled(df, col, rows, k, name)
    for col in OPTIONAL_COLUMNS:
        if col not in df.columns:
            df[col] = np.nan
        df[col] = _numbers(df[col], col, name)
    _check_values(df, kind.to_numpy(), name)
    spam = _check_prepared(df, kind.to_numpy(), name)
    ramsey = _check_sequence(df, kind.to_numpy(), name)
    linearity = _check_attenuation(df, kind.to_numpy(), name)
    thermo = _check_thermometry(df, kind.to_numpy(), name)
    _check_repeats(df, name)
    # counts as integers (empty where a kind has none), so that the table reads as written
    for col in ("repeat", "point"):
        df[col] = df[col].astype("int64")
    for col in ("dpd", "shots", "day"):
        df[col] = df[col].round().astype("Int64")
    waited = ramsey or thermo      # ``wait_us`` is shared by both
    return df[list(SCHEDULE_COLUMNS) + ([_PREPARED] if spam else [])
              + (["sequence"] if ramsey else []) + (["wait_us"] if waited else [])
              + ([LINEARITY_COLUMN] if linearity else []) + (["sideband"] if thermo else [])]


def _check_thermometry(df: pd.DataFrame, kind: np.ndarray, name: str) -> bool:
    """Each ``thermometry`` row's ``wait_us`` is ``>= 0`` and finite and its ``sideband``
    ``red`` or ``blue`` (empty on the other rows); whether the schedule has such rows."""
    rows = kind == "thermometry"
    if not rows.any():
        return False
    if "sideband" not in df.columns:
        _fail("column 'sideband' is missing (the 'thermometry' rows need it)", name)
    w = df["wait_us"].to_numpy(float)
    bad = np.flatnonzero(rows & ~(w >= 0))
    if bad.size:
        _fail(f"wait {w[bad[0]]:g} us must be >= 0", name, "wait_us", bad[0])
    text = df["sideband"].astype("string").fillna("").str.strip().str.lower().to_numpy(
        dtype=object)
    bad = np.flatnonzero(rows & ~np.isin(text, _SIDEBANDS))
    if bad.size:
        _fail(f"sideband {text[bad[0]]!r} does not exist (the sidebands: "
              f"{', '.join(_SIDEBANDS)})", name, "sideband", bad[0])
    df["wait_us"] = np.where(np.isin(kind, _WAITED), w, np.nan)
    df["sideband"] = np.where(rows, text, "")
    return True


def _check_prepared(df: pd.DataFrame, kind: np.ndarray, name: str) -> bool:
    """Each ``spam`` row's ``prepared`` is a basis state (text ``00`` .. ``11``; empty on
    the other rows); whether the schedule has ``spam`` rows."""
    spam = kind == "spam"
    if not spam.any():
        return False
    if _PREPARED not in df.columns:
        _fail(f"column '{_PREPARED}' is missing (the 'spam' rows need it)", name)
    text = df[_PREPARED].astype("string").fillna("").str.strip().to_numpy(dtype=object)
    bad = np.flatnonzero(spam & ~np.isin(text, _BASIS_STATES))
    if bad.size:
        _fail(f"prepared state {text[bad[0]]!r} does not exist (the basis states: "
              f"{', '.join(_BASIS_STATES)})", name, _PREPARED, bad[0])
    df[_PREPARED] = np.where(spam, text, "")
    return True


def _check_sequence(df: pd.DataFrame, kind: np.ndarray, name: str) -> bool:
    """Each ``ramsey`` row's ``sequence`` is ``ramsey`` or ``echo`` and its ``wait_us`` a
    wait (>= 0; both empty on the other rows); whether the schedule has ``ramsey``
    rows."""
    rows = kind == "ramsey"
    if not rows.any():
        return False
    if "sequence" not in df.columns:
        _fail("column 'sequence' is missing (the 'ramsey' rows need it)", name)
    text = df["sequence"].astype("string").fillna("").str.strip().str.lower().to_numpy(
        dtype=object)
    bad = np.flatnonzero(rows & ~np.isin(text, _SEQUENCES))
    if bad.size:
        _fail(f"sequence {text[bad[0]]!r} does not exist (the sequences: "
              f"{', '.join(_SEQUENCES)})", name, "sequence", bad[0])
    wait = df["wait_us"].to_numpy(float)
    bad = np.flatnonzero(rows & ~(wait >= 0))
    if bad.size:
        _fail(f"wait {wait[bad[0]]:g} us is below zero", name, "wait_us", bad[0])
    df["sequence"] = np.where(rows, text, "")
    df["wait_us"] = np.where(np.isin(kind, _WAITED), wait, np.nan)
    return True


def _check_attenuation(df: pd.DataFrame, kind: np.ndarray, name: str) -> bool:
    """Each ``detector_linearity`` row's ``attenuation_db`` a number > 0 (NaN on the other
    rows); whether the schedule has such rows."""
    rows = np.isin(kind, LINEARITY_KINDS)
    if not rows.any():
        return False
    if LINEARITY_COLUMN not in df.columns:
        _fail(f"column '{LINEARITY_COLUMN}' is missing (the 'detector_linearity' rows need "
              "it)", name)
    v = _numbers(df[LINEARITY_COLUMN], LINEARITY_COLUMN, name).to_numpy(float)
    bad = np.flatnonzero(rows & ~((v > 0) & np.isfinite(v)))
    if bad.size:
        _fail(f"attenuation {v[bad[0]]:g} dB must be > 0 (an attenuator attenuates)", name,
              LINEARITY_COLUMN, bad[0])
    df[LINEARITY_COLUMN] = np.where(rows, v, np.nan)
    return True


def _check_values(df: pd.DataFrame, kind: np.ndarray, name: str) -> None:
    runs = np.isin(kind, RUN_KINDS + LINEARITY_KINDS)
    ungated = np.isin(kind, _UNGATED)
    A = df["A"].to_numpy(float)
    bad = np.flatnonzero(~((A >= 0) & (A <= 1)) | (~runs & ~ungated & (A == 0))
                         | (ungated & (A != 0)))
    if bad.size:
        where = ("0 (no gate is driven)" if ungated[bad[0]] else
                 "[0, 1]" if runs[bad[0]] else "(0, 1]")
        _fail(f"amplitude {A[bad[0]]:g} is outside {where}" if not ungated[bad[0]] else
              f"amplitude {A[bad[0]]:g} of a {kind[bad[0]]} point must be {where}",
              name, "A", bad[0])
    flagged = ~runs & ~np.isin(kind, CHARACTERISATION_KINDS)
    d = df["dpd"].to_numpy(float)
    bad = np.flatnonzero(flagged & ~np.isin(d, (0.0, 1.0)))
    if bad.size:
        _fail(f"dpd {d[bad[0]]:g} is not a flag (0 or 1)", name, "dpd", bad[0])
    _integers(df, "shots", np.isin(kind, SCAN_KINDS + _UNGATED), 1, name)
    for col in ("t_us", "lab_s", "start_s"):
        v = df[col].to_numpy(float)
        bad = np.flatnonzero(np.isfinite(v) & (v < 0) | np.isinf(v))
        if bad.size:
            _fail(f"{v[bad[0]]:g} must be >= 0 and finite", name, col, bad[0])
    day = df["day"].to_numpy(float)
    _integers(df, "day", ~np.isnan(day), 0, name)
    v = df["tone_sd_db"].to_numpy(float)
    bad = np.flatnonzero(~np.isnan(v) & ~((v > 0) & np.isfinite(v)))
    if bad.size:
        _fail(f"{v[bad[0]]:g} must be > 0 and finite", name, "tone_sd_db", bad[0])


def _check_repeats(df: pd.DataFrame, name: str) -> None:
    """Points unique within a repeat; a scan's setting and shots constant within it."""
    dup = np.flatnonzero(df.duplicated(["kind", "repeat", "point"]).to_numpy())
    if dup.size:
        r = df.iloc[dup[0]]
        _fail(f"point {int(r['point'])} of {r['kind']} repeat {int(r['repeat'])} appears twice",
              name, "point", dup[0])
    if (df["kind"] == "spectra").any():
        sp = df[df["kind"] == "spectra"]
        twice = np.flatnonzero(sp.duplicated(["repeat", "A", "dpd"]).to_numpy())
        if twice.size:
            _fail("a trace (A, dpd) appears twice in one repeat", name, "A",
                  sp.index[twice[0]])
    for k, cols in _CONSTANT.items():
        sub = df[df["kind"] == k]
        for col in cols:
            first = sub.groupby("repeat")[col].transform("first").to_numpy(float)
            bad = np.flatnonzero(sub[col].to_numpy(float) != first)
            if bad.size:
                _fail(f"{col} changes within {k} repeat {int(sub['repeat'].iloc[bad[0]])}",
                      name, col, sub.index[bad[0]])


def read_schedule(path: str | os.PathLike) -> pd.DataFrame:
    """Read and check a schedule file (module doc).

    Parameters
    ----------
    path : path-like
        The schedule CSV (``#`` lines are comments).

    Returns
    -------
    pandas.DataFrame
        The columns of :data:`SCHEDULE_COLUMNS` (an absent optional column as NaN).

    Raises
    ------
    InputError
        One line naming the file, the column and the row: an unknown kind, a negative
        or fractional number of shots, an amplitude outside [0, 1], a flag that is not
        0 or 1, a point listed twice, a setting that changes within one scan, a day that
        is not a whole number >= 0, a negative start, a tone sd <= 0, text where a
        number belongs.  The file
        is read through :func:`~dpdfit.recordings.tables.read_table`: a FIFO or device
        is refused unread, and a file of more than
        :data:`~dpdfit.core.defaults.MAX_SCHEDULE_ROWS` rows as soon as its reading
        passes that many, the rest not read.
    """
    name = str(path)
    df = read_table(path, ["kind", "repeat", "point", "A"],
                    list(OPTIONAL_COLUMNS) + [_PREPARED, *_RAMSEY, _THERMOMETRY[1]],
                    numeric=["repeat", "point", "A"], max_rows=MAX_SCHEDULE_ROWS)
    return check_schedule(df, name)


def write_schedule(schedule: pd.DataFrame, path: str | os.PathLike) -> None:
    """Write a schedule (checked first) to ``path`` atomically; empty cells stay empty."""
    df = check_schedule(schedule, str(path))
    atomic_write_text(path, csv_table_text(df, path))   # floats as shortest round trip
