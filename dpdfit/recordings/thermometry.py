"""``thermometry.csv``: the lab's sideband thermometry of the gate mode after a variable wait.

The gate mode is cooled, left to heat for ``wait_us`` microseconds, and probed with a
short pulse on its red or blue motional sideband; the probed ion is then read out.  The
ratio of the red to the blue sideband's excitation gives the mode's mean occupation at
each wait, so the recording measures the initial mean phonon number and the heating
rate directly, which the gate recordings see only through the gate fidelity (where a
preparation error, dephasing and heating look alike).

Layout (one row per recording of one wait and one sideband): ``wait_us`` (the wait
after cooling before the probe, microseconds, ``>= 0``), ``sideband`` (``red`` or
``blue``), ``n_bright`` (the shots in which the probed ion, the first of the chain, read
bright after the sideband pulse: it starts bright in ``0`` and a sideband excitation
takes it dark to ``1``), ``shots``; optional ``run`` and ``timestamp`` (labels).
:func:`read_thermometry` checks every row like the count tables
(:func:`~dpdfit.recordings.counts.check_counts`): a problem is one
:class:`~dpdfit.errors.InputError` naming the file, the column and the data row.  A
wait longer than :data:`MAX_WAIT_US` is refused as a unit slip
(:class:`~dpdfit.errors.ImplausibleValueError`, :mod:`~dpdfit.recordings.plausibility`).
A point (wait, sideband) recorded again is a further row; its rows are pooled (counts
and shots summed) unless they contradict binomial noise
(:func:`~dpdfit.recordings.counts.check_count_repeats`).
"""

from __future__ import annotations

import os

import numpy as np
import pandas as pd

from dpdfit.errors import ImplausibleValueError, InputError

from .columns import CAMPAIGN_TABLES
from .counts import check_count_repeats, check_counts
from .tables import read_table

__all__ = ["read_thermometry", "SIDEBANDS", "MAX_WAIT_US"]

#: the sidebands a thermometry row may probe
SIDEBANDS = ("red", "blue")
#: the longest plausible wait (us): one second.  A heating-rate measurement waits up to
#: tens of milliseconds (a mode heating at tens of quanta per second leaves the
#: Lamb-Dicke regime within a second); a wait in nanoseconds written under ``_us`` is a
#: thousand times too large and lands beyond it.
MAX_WAIT_US = 1e6


def _check_sideband(df: pd.DataFrame, file: str) -> None:
    """Every ``sideband`` is one of :data:`SIDEBANDS` (case and blanks ignored)."""
    sb = df["sideband"].astype(str).str.strip().str.lower().to_numpy(dtype=object)
    bad = ~np.isin(sb, SIDEBANDS)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"sideband {str(df['sideband'].iloc[i])!r} does not exist: the "
                         f"sidebands are {', '.join(SIDEBANDS)}", file=file,
                         column="sideband", row=i + 1)
    df["sideband"] = sb.astype(str)


def _check_waits(df: pd.DataFrame, file: str) -> None:
    """``0 <= wait_us <= MAX_WAIT_US`` (above it: a unit slip, refused as implausible)."""
    w = df["wait_us"].to_numpy(dtype=float)
    bad = w < 0
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"wait {w[i]:g} us is negative: the probe follows the cooling",
                         file=file, column="wait_us", row=i + 1)
    bad = w > MAX_WAIT_US
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ImplausibleValueError(
            f"wait {w[i]:g} us is above {MAX_WAIT_US:g} us (1 s), longer than any heating "
            "measurement: a wait in ns written as us?", file=file, column="wait_us",
            row=i + 1)


def read_thermometry(path: str | os.PathLike, *, within=None) -> pd.DataFrame:
    """Read, validate and pool a thermometry file ``wait_us, sideband, n_bright, shots``
    (+ ``run``, ``timestamp``).

    ``wait_us`` in ``[0, MAX_WAIT_US]``; ``sideband`` one of :data:`SIDEBANDS`; counts
    non-negative integers at most ``shots``, ``shots >= 1``.  Rows of one point
    ``(wait_us, sideband)`` are pooled (module doc).  ``within``: the folder the file
    must lie in (a campaign folder, :func:`~dpdfit.recordings.tables.read_csv_strings`).

    Returns
    -------
    pandas.DataFrame
        One row per point in order of its first row (the index is that row's 0-based
        data row): ``wait_us``, ``sideband`` (str), ``n_bright`` and ``shots`` (float64),
        ``wait_s`` the wait in seconds, ``n_repeats`` the rows pooled.
    """
    name = str(path)
    required, optional = (list(c) for c in CAMPAIGN_TABLES["thermometry"])
    df = read_table(path, required, optional, numeric=["wait_us", "n_bright", "shots"],
                    within=within)
    _check_waits(df, name)
    _check_sideband(df, name)
    check_counts(df, ["n_bright", "shots"], name)
    keys = ["wait_us", "sideband"]
    check_count_repeats(df, keys, ["n_bright"], name, "thermometry point")
    g = df.groupby(keys, sort=False)
    first = ~df.duplicated(keys).to_numpy()
    out = df[first].copy()
    out[["n_bright", "shots"]] = g[["n_bright", "shots"]].sum().to_numpy(dtype=float)
    out["n_repeats"] = g.size().to_numpy()
    out["wait_s"] = out["wait_us"] * 1e-6
    out.attrs["source"] = name
    return out
