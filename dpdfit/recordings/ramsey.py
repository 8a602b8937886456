"""``ramsey.csv``: the lab's Ramsey and spin-echo characterisation of the two-ion chain.

Both ions are prepared in ``00`` and driven together: a pi/2 pulse, a free-precession wait
``wait_us``, a second pi/2 pulse in phase with the first, then both ions detected.  The
spin echo (``sequence`` ``echo``) adds a pi pulse about the orthogonal axis half-way
through the wait (a Hahn echo), so that in both sequences a fully coherent ion ends dark
(``1``) and a fully dephased one is dark half the time.  The Ramsey sequence gives the
coherence time with all dephasing; the echo refocuses slow noise (a frequency offset
constant over one shot) and not white noise, so the two together say which the noise is.

One row per recorded point: ``sequence`` (``ramsey`` or ``echo``), ``wait_us`` (the whole
free-precession wait, microseconds, the echo's pi pulse not counted), ``n00, n01_10,
n11`` (the detected outcomes of the two ions, counts of shots, as ``populations.csv``
records them) and ``shots``; optional ``run`` and ``timestamp`` (labels).
:func:`read_ramsey` checks every row like the count tables
(:func:`~dpdfit.recordings.counts.check_counts`): a problem is one
:class:`~dpdfit.errors.InputError` naming the file, the column and the data row.  A
point recorded again is a further row; its rows are pooled (counts and shots summed)
unless they contradict binomial noise
(:func:`~dpdfit.recordings.counts.check_count_repeats`).

A wait in the wrong unit (seconds or nanoseconds in the ``_us`` column) is refused
against the campaign's stated coherence time (:func:`check_ramsey_waits`).
"""

from __future__ import annotations

import os

import numpy as np
import pandas as pd

from dpdfit.errors import ImplausibleValueError, InputError

from .columns import CAMPAIGN_TABLES
from .counts import check_count_repeats, check_counts, check_outcomes_sum_to_shots
from .tables import read_table

__all__ = ["read_ramsey", "check_ramsey_waits", "SEQUENCES", "OUTCOMES",
           "WAIT_ABOVE_T2", "LONGEST_WAIT_BELOW_T2"]

#: the sequences a row may record
SEQUENCES = ("ramsey", "echo")
#: the detected-outcome columns, in the order the diagnosis predicts them
OUTCOMES = ("n00", "n01_10", "n11")
#: a wait more than this many coherence times is refused: the coherence is gone after a
#: few T2 (a scan reaches 1 to 3 T2), while a wait written in ns under the ``_us``
#: label is 1000 times too long
WAIT_ABOVE_T2 = 100.0
#: a scan whose longest wait is below this fraction of T2 is refused: white dephasing
#: of the stated T2 costs it at most 1 % of the contrast, so it could not measure the
#: coherence it is recorded for (a scan reaches 1 to 3 T2), while waits written in ms or
#: s under the ``_us`` label are 1e3 or 1e6 times too short
LONGEST_WAIT_BELOW_T2 = 1e-2


def _check_sequence(df: pd.DataFrame, file: str) -> None:
    """Every ``sequence`` is one of :data:`SEQUENCES` (case and spaces ignored)."""
    seq = df["sequence"].astype(str).str.strip().str.lower().to_numpy(dtype=object)
    bad = ~np.isin(seq, SEQUENCES)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"sequence {str(df['sequence'].iloc[i])!r} does not exist: the "
                         f"sequences are {', '.join(SEQUENCES)}", file=file,
                         column="sequence", row=i + 1)
    df["sequence"] = seq.astype(str)


def _check_waits(df: pd.DataFrame, file: str) -> None:
    wait = df["wait_us"].to_numpy(dtype=float)
    bad = wait < 0
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"wait {wait[i]:g} us is below zero", file=file, column="wait_us",
                         row=i + 1)


def read_ramsey(path: str | os.PathLike, *, within=None) -> pd.DataFrame:
    """Read, validate and pool a Ramsey file ``sequence, wait_us, n00, n01_10, n11,
    shots`` (+ ``run``, ``timestamp``).

    ``sequence`` one of :data:`SEQUENCES`; ``wait_us >= 0``; counts non-negative
    integers at most ``shots``, ``shots >= 1``; ``n00 + n01_10 + n11 == shots``.  Rows
    of one point ``(sequence, wait_us)`` are pooled (module doc).  ``within``: the folder
    the file must lie in (a campaign folder,
    :func:`~dpdfit.recordings.tables.read_csv_strings`).

    Returns
    -------
    pandas.DataFrame
        One row per point in order of its first row (the index is that row's 0-based
        data row): ``sequence`` (str), ``wait_us``, the counts and ``shots`` (float64),
        ``wait_s`` the wait in seconds, ``n_repeats`` the rows pooled.
    """
    name = str(path)
    required, optional = (list(c) for c in CAMPAIGN_TABLES["ramsey"])
    df = read_table(path, required, optional, numeric=["wait_us", *OUTCOMES, "shots"],
                    within=within)
    _check_sequence(df, name)
    _check_waits(df, name)
    check_counts(df, [*OUTCOMES, "shots"], name)
    check_outcomes_sum_to_shots(df, name)
    keys = ["sequence", "wait_us"]
    check_count_repeats(df, keys, list(OUTCOMES), name, "Ramsey point")
    g = df.groupby(keys, sort=False)
    first = ~df.duplicated(keys).to_numpy()
    out = df[first].copy()
    out[[*OUTCOMES, "shots"]] = g[[*OUTCOMES, "shots"]].sum().to_numpy(dtype=float)
    out["n_repeats"] = g.size().to_numpy()
    out["wait_s"] = out["wait_us"].to_numpy(dtype=float) * 1e-6
    out.attrs["source"] = name
    return out


def check_ramsey_waits(df: pd.DataFrame, T2_s: float, file: str, source: str) -> None:
    """Refuse waits that contradict the campaign's coherence time ``T2_s`` (s): a wait
    above :data:`WAIT_ABOVE_T2` times it (ns written as us), or a longest wait below
    :data:`LONGEST_WAIT_BELOW_T2` times it (s or ms written as us); one
    :class:`~dpdfit.errors.ImplausibleValueError` naming the row (``df`` as
    :func:`read_ramsey` gives it: the index is the first data row of each point).
    ``source`` names where ``T2_s`` comes from."""
    if df.empty or not (np.isfinite(T2_s) and T2_s > 0):
        return
    wait = df["wait_us"].to_numpy(dtype=float) * 1e-6
    rows = np.asarray(df.index, dtype=int) + 1
    high = wait > WAIT_ABOVE_T2 * T2_s
    if high.any():
        i = int(np.flatnonzero(high)[0])
        raise ImplausibleValueError(
            f"wait {wait[i] * 1e6:g} us is {wait[i] / T2_s:.3g} coherence times T2 = "
            f"{T2_s * 1e3:g} ms ({source}), more than {WAIT_ABOVE_T2:g}: stored in ns with "
            "unit us?", file=file, column="wait_us", row=int(rows[i]))
    i = int(np.argmax(wait))
    if wait[i] < LONGEST_WAIT_BELOW_T2 * T2_s:
        raise ImplausibleValueError(
            f"longest wait {wait[i] * 1e6:g} us is below {LONGEST_WAIT_BELOW_T2:g} of the "
            f"coherence time T2 = {T2_s * 1e3:g} ms ({source}): no decay could be seen; "
            "stored in s or ms with unit us?", file=file, column="wait_us", row=int(rows[i]))
