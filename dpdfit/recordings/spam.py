"""``spam.csv``: the lab's SPAM characterisation, each basis state prepared and detected
with no gate.

The experiment measures the preparation and detection errors directly, which the gate
recordings see only through the gate fidelity (where a preparation error, dephasing and
heating look alike).  One row per recording of a prepared state: ``prepared`` (the basis
state, ``00``, ``01``, ``10`` or ``11``: the first character the first ion), ``n00,
n01_10, n11`` (the detected outcomes, as ``populations.csv`` records them) and ``shots``;
optional ``run`` and ``timestamp`` (labels).  :func:`read_spam` checks every row like the
count tables (:func:`~dpdfit.recordings.counts.check_counts`): a problem is one
:class:`~dpdfit.errors.InputError` naming the file, the column and the data row.  A state
prepared again is a further row; its rows are pooled (counts and shots summed) unless
they contradict binomial noise (:func:`~dpdfit.recordings.counts.check_count_repeats`).
"""

from __future__ import annotations

import os

import numpy as np
import pandas as pd

from dpdfit.errors import InputError

from .columns import CAMPAIGN_TABLES
from .counts import check_count_repeats, check_counts, check_outcomes_sum_to_shots
from .tables import read_table

__all__ = ["read_spam", "BASIS_STATES", "OUTCOMES"]

#: the basis states a SPAM row may prepare (first character: the first ion)
BASIS_STATES = ("00", "01", "10", "11")
#: the detected-outcome columns, in the order the diagnosis predicts them
OUTCOMES = ("n00", "n01_10", "n11")


def _check_prepared(df: pd.DataFrame, file: str) -> None:
    """Every ``prepared`` is one of :data:`BASIS_STATES` (text, as written)."""
    prepared = df["prepared"].astype(str).str.strip().str.strip("|>").to_numpy(dtype=object)
    bad = ~np.isin(prepared, BASIS_STATES)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        value = str(df["prepared"].iloc[i])
        hint = (" (a spreadsheet that dropped a leading zero?)"
                if value.strip() in ("0", "1") else "")
        raise InputError(f"prepared state {value!r} does not exist: the basis states are "
                         f"{', '.join(BASIS_STATES)}{hint}", file=file, column="prepared",
                         row=i + 1)
    df["prepared"] = prepared.astype(str)


def read_spam(path: str | os.PathLike, *, within=None) -> pd.DataFrame:
    """Read, validate and pool a SPAM file ``prepared, n00, n01_10, n11, shots``
    (+ ``run``, ``timestamp``).

    ``prepared`` one of :data:`BASIS_STATES` (``|00>`` is read as ``00``); counts
    non-negative integers at most ``shots``, ``shots >= 1``; ``n00 + n01_10 + n11 ==
    shots``.  Rows of one prepared state are pooled (module doc).
    ``within``: the folder the file must lie in (a campaign folder,
    :func:`~dpdfit.recordings.tables.read_csv_strings`).

    Returns
    -------
    pandas.DataFrame
        One row per prepared state in order of its first row (the index is that row's
        0-based data row): ``prepared`` (str), the counts and ``shots`` (float64),
        ``n_repeats`` the rows pooled.
    """
    name = str(path)
    required, optional = (list(c) for c in CAMPAIGN_TABLES["spam"])
    df = read_table(path, required, optional, numeric=[*OUTCOMES, "shots"], within=within)
    _check_prepared(df, name)
    check_counts(df, [*OUTCOMES, "shots"], name)
    check_outcomes_sum_to_shots(df, name)
    check_count_repeats(df, ["prepared"], list(OUTCOMES), name, "SPAM preparation")
    g = df.groupby("prepared", sort=False)
    first = ~df.duplicated(["prepared"]).to_numpy()
    out = df[first].copy()
    out[[*OUTCOMES, "shots"]] = g[[*OUTCOMES, "shots"]].sum().to_numpy(dtype=float)
    out["n_repeats"] = g.size().to_numpy()
    out.attrs["source"] = name
    return out
