"""Readers of count recordings: ``populations.csv`` and ``parity.csv`` (Supplement S7).

:func:`read_populations` and :func:`read_parity` read a file through
:func:`~dpdfit.recordings.tables.read_table` and check every count once
(integer, non-negative, at most ``shots``, at least one shot), the settings
(``dpd`` 0 or 1, ``A`` in [0, 1]), the scan labels and duplicated rows, and the
parity fringe's design (at least 3 distinct analysis phases, no scan spanning
degrees: :mod:`dpdfit.recordings.plausibility`).  A problem is one
:class:`~dpdfit.errors.InputError` naming the file, the column and the data
row.  The few checks that the fits repeat on frames built in Python
(:func:`check_counts`, :func:`fringe_points`, :func:`grid_keys`) are public
here so that they are written once.
"""

from __future__ import annotations

import math
import os

import numpy as np
import pandas as pd
from scipy.stats import hypergeom, norm

from dpdfit.errors import ImplausibleValueError, InputError, data_line

from .columns import CAMPAIGN_TABLES
from .plausibility import check_phase_span
from .tables import read_table

__all__ = ["PHASE_GRID_RAD", "COUNT_Z_MAX", "read_populations", "read_parity", "read_time_scans",
           "check_counts", "check_count_repeats", "grid_keys", "fringe_points", "setting_label",
           "shots_below_one", "check_outcomes_sum_to_shots"]

#: Phase grid (rad) on which repeated parity scans are compared and merged (S7.4).
PHASE_GRID_RAD = 0.01
#: repeated counts of one point contradict when their exact p-value, over all the
#: table's repeated rows, is below the two-sided normal tail of this many sigma
COUNT_Z_MAX = 6.0


def shots_below_one(shots) -> str:
    """The message refusing ``shots < 1`` (one line, with the likely slip)."""
    return (f"shots = {float(shots):g} is below 1 (a row with no shots): an aborted scan, "
            "or a fraction or probability in place of the number of shots?")


def setting_label(A, dpd) -> str:
    """``"A=0.8, dpd=1"``: a setting as named in messages."""
    return f"A={float(A):g}, dpd={int(dpd)}"


def grid_keys(phases, grid: float) -> np.ndarray:
    """Index ``round(phi / grid)`` of the phase-grid point nearest to each phase (ties up)."""
    return np.floor(np.asarray(phases, dtype=float) / grid + 0.5).astype(np.int64)


def fringe_points(phases, tol=1e-9, period=math.pi) -> int:
    """Number of distinct phases modulo ``period`` (circular, within ``tol``).

    ``period = pi``: distinct fringe points (phi and phi + pi measure the same
    p).  ``period = pi/2``: distinct fringe *axes* (phi + pi/2 measures
    ``1 - p``, the same linear functional of (a, b)); the fit needs >= 2.
    """
    x = np.sort(np.mod(phases, period))
    if x.size == 0:
        return 0
    gaps = np.diff(np.concatenate([x, [x[0] + period]]))
    return max(int(np.sum(gaps > tol)), 1)


def _plain(value) -> str:
    """A cell as plain text: ``623.5``, not ``np.float64(623.5)``; text quoted."""
    if isinstance(value, (int, float, np.integer, np.floating)):
        return f"{float(value):g}"
    return repr(str(value))


def check_counts(df: pd.DataFrame, cols, file) -> None:
    """Check the count columns ``cols`` (with ``shots``) of ``df``: integer, non-negative,
    ``shots >= 1``, counts <= shots; InputError naming ``file``, column and row (position + 1)."""
    vals = {c: pd.to_numeric(df[c], errors="coerce").to_numpy(dtype=float) for c in cols}
    few = vals["shots"] < 1
    if few.any():
        i = int(np.flatnonzero(few)[0])
        raise ImplausibleValueError(shots_below_one(vals["shots"][i]), file=file,
                                    column="shots", row=i + 1)
    for c in cols:
        arr = vals[c]
        bad = ~(arr == np.round(arr))                 # also NaN and non-numbers
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"count {_plain(df[c].iloc[i])} is not an integer", file=file,
                             column=c, row=i + 1)
        bad = arr < 0
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"count {arr[i]:g} is negative", file=file, column=c, row=i + 1)
    shots = vals["shots"]
    for c in cols:
        if c == "shots":
            continue
        bad = vals[c] > shots
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"count {vals[c][i]:g} exceeds shots = {shots[i]:g}", file=file,
                             column=c, row=i + 1)


def _check_dpd(df, file):
    arr = df["dpd"].to_numpy(dtype=float)
    bad = (arr != 0) & (arr != 1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"dpd = {arr[i]:g} must be 0 or 1", file=file, column="dpd", row=i + 1)
    df["dpd"] = arr.astype(np.int64)


def _check_scan(df, file):
    empty = df["scan"] == ""
    if empty.any():
        i = int(np.flatnonzero(empty.to_numpy())[0])
        raise InputError("scan label is empty", file=file, column="scan", row=i + 1)


def _check_unique(df, keys, file, what):
    dup = df.duplicated(keys, keep=False)
    if dup.any():
        idx = np.flatnonzero(dup.to_numpy())
        first = df.iloc[idx[0]]
        same = [int(i) + 1 for i in idx if all(df.iloc[i][k] == first[k] for k in keys)]
        label = ", ".join(f"{k}={first[k]}" for k in keys)
        raise InputError(f"{what} {label} appears in more than one row "
                         f"({_rows_text(file, same[:6])}): a duplicated line?",
                         file=file, column=keys[-1], row=same[1])


def _rows_text(file, rows) -> str:
    """``"rows 2, 5 (lines 4, 7)"``: data rows named in a message, with their file lines."""
    lines = [data_line(file, r) for r in rows] if file is not None else [None]
    text = f"rows {', '.join(map(str, rows))}"
    if None in lines:
        return text
    return text + f" (lines {', '.join(map(str, lines))})"


def check_outcomes_sum_to_shots(df, file) -> None:
    """``n00 + n01_10 + n11 == shots`` on every row, else one line naming the first."""
    tot = df["n00"] + df["n01_10"] + df["n11"]
    bad = (tot != df["shots"]).to_numpy()
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"n00 + n01_10 + n11 = {tot.iloc[i]:g} differs from shots = "
                         f"{df['shots'].iloc[i]:g}", file=file, column="shots", row=i + 1)


def _check_trio(df, file):
    """``n00 + n01_10 + n11 == shots``; ``n_even == n00 + n11`` (added when absent)."""
    check_outcomes_sum_to_shots(df, file)
    even = df["n00"] + df["n11"]
    if "n_even" in df.columns:
        bad = (even != df["n_even"]).to_numpy()
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"n_even = {df['n_even'].iloc[i]:g} differs from n00 + n11 = "
                             f"{even.iloc[i]:g}", file=file, column="n_even", row=i + 1)
    else:
        df["n_even"] = even


def read_populations(path: str | os.PathLike, *, within=None) -> pd.DataFrame:
    """Read and validate a population file.

    Columns ``A, dpd, scan, n_even, shots`` or ``A, dpd, scan, n00, n01_10,
    n11, shots`` (then ``n_even = n00 + n11`` and ``n00 + n01_10 + n11 ==
    shots`` is required; with both forms present ``n_even`` must equal
    ``n00 + n11``).  Extra columns allowed, ``#`` lines are comments.

    Bad input raises InputError naming file, column and row: counts not
    integer, negative or above ``shots``; ``shots < 1``; ``dpd`` not 0/1;
    ``A`` outside [0, 1]; the same ``(A, dpd, scan)`` in two rows.
    ``within``: the folder the file must lie in (a campaign folder,
    :func:`~dpdfit.recordings.tables.read_csv_strings`).

    Returns
    -------
    pandas.DataFrame
        Numeric columns as float64 (``dpd`` int, ``scan`` str), ``n_even``
        always present; the index is the 0-based data row.
    """
    name = str(path)
    required, optional = (list(c) for c in CAMPAIGN_TABLES["populations"])
    df = read_table(path, required, optional,
                    numeric=["A", "dpd", "shots"] + optional, ranges={"A": (0.0, 1.0)},
                    within=within)
    trio = [c for c in ("n00", "n01_10", "n11") if c in df.columns]
    if "n_even" not in df.columns and len(trio) < 3:
        missing = next(c for c in ("n00", "n01_10", "n11") if c not in df.columns)
        raise InputError("required column is missing (give n_even, or n00, n01_10 and n11)",
                         file=name, column=missing if trio else "n_even")
    _check_dpd(df, name)
    _check_scan(df, name)
    counts = (["n_even"] if "n_even" in df.columns else []) + (trio if len(trio) == 3 else [])
    check_counts(df, counts + ["shots"], name)
    if len(trio) == 3:
        _check_trio(df, name)
    _check_unique(df, ["A", "dpd", "scan"], name, "population setting")
    df.attrs["source"] = name
    return df


def _check_phase_duplicates(df, grid, file):
    """The same phase-grid point twice in one scan of a setting: a duplicated line."""
    key = pd.Series(grid_keys(df["phase_rad"], grid), index=df.index, name="_key")
    cols = [df["A"], df["dpd"], df["scan"], key]
    dup = pd.concat(cols, axis=1).duplicated(keep=False)
    if dup.any():
        idx = np.flatnonzero(dup.to_numpy())
        ref = (df["A"].iloc[idx[0]], df["dpd"].iloc[idx[0]], df["scan"].iloc[idx[0]],
               key.iloc[idx[0]])
        same = [int(i) + 1 for i in idx
                if (df["A"].iloc[i], df["dpd"].iloc[i], df["scan"].iloc[i], key.iloc[i]) == ref]
        raise InputError(
            f"setting {setting_label(ref[0], ref[1])}, scan {ref[2]}: phase "
            f"{df['phase_rad'].iloc[idx[0]]:.6g} rad appears twice ({_rows_text(file, same[:2])}"
            f", same {grid:g}-rad grid point): a duplicated line?", file=file,
            column="phase_rad", row=same[1])


def _check_fringe_design(df, grid, file):
    """Every setting has >= 3 distinct phases modulo pi, not all on one fringe axis."""
    for (A, dpd), g in df.groupby(["A", "dpd"], sort=False):
        if fringe_points(g["phase_rad"].to_numpy(), tol=grid / 2) < 3:
            ph = np.unique(np.round(np.mod(g["phase_rad"].to_numpy(), math.pi), 6))
            raise InputError(
                f"setting {setting_label(A, dpd)} has only {ph.size} distinct analysis "
                f"phase(s) modulo pi ({', '.join(f'{p:g}' for p in ph[:5])}); a parity "
                "fringe fit needs at least 3", file=file, column="phase_rad",
                row=int(g.index[0]) + 1)
        if fringe_points(g["phase_rad"].to_numpy(), tol=grid / 2, period=math.pi / 2) < 2:
            raise InputError(
                f"setting {setting_label(A, dpd)}: all analysis phases are equal modulo "
                "pi/2 (one fringe axis: 2*phi equal modulo pi), so contrast and phase offset "
                "cannot be separated; a degenerate fringe fit", file=file,
                column="phase_rad", row=int(g.index[0]) + 1)


def read_parity(path: str | os.PathLike, grid: float = PHASE_GRID_RAD, *, within=None
                ) -> pd.DataFrame:
    """Read and validate a parity-fringe file ``A, dpd, scan, phase_rad, n_even, shots``.

    Bad input raises InputError naming file, column and row: counts not
    integer, negative or above ``shots``; ``shots < 1``; ``dpd`` not 0/1;
    ``A`` outside [0, 1]; the same phase grid point twice in one scan; a
    setting with fewer than 3 distinct analysis phases (modulo pi, since
    ``phi`` and ``phi + pi`` measure the same fringe point), or with all its
    phases on one fringe axis (equal modulo pi/2).  Scans whose phases jitter
    around a common set are accepted (see
    :func:`dpdfit.fits.counts.merge_parity`).  Phases spanning more than
    :data:`~dpdfit.recordings.plausibility.DEGREES_SPAN_RAD` in one scan are
    refused (degrees; radians are expected).
    ``within``: the folder the file must lie in (a campaign folder,
    :func:`~dpdfit.recordings.tables.read_csv_strings`).

    Returns
    -------
    pandas.DataFrame
        As read (``dpd`` int, ``scan`` str); the index is the 0-based data row.
    """
    name = str(path)
    df = read_table(path, list(CAMPAIGN_TABLES["parity"][0]),
                    numeric=["A", "dpd", "phase_rad", "n_even", "shots"],
                    ranges={"A": (0.0, 1.0)}, within=within)
    _check_dpd(df, name)
    _check_scan(df, name)
    check_counts(df, ["n_even", "shots"], name)
    check_phase_span(df, "phase_rad", ["A", "dpd", "scan"], name,
                     lambda k: f"setting {setting_label(k[0], k[1])}, scan {k[2]}")
    _check_phase_duplicates(df, grid, name)
    _check_fringe_design(df, grid, name)
    if not float(grid) > 0:                       # as merge_parity requires
        raise InputError(f"phase grid {float(grid):g} must be > 0")
    df.attrs["source"] = name
    return df


def _conditional_p(k, kg, N, Ng) -> np.ndarray:
    """Two-sided p-value of each row's count ``k`` (of ``N`` shots) given its point's
    total ``kg`` (of ``Ng``), hypergeometric under one common probability.  Exact: for
    rare outcomes a count of 2 beside hundreds of zeros is 8 normal sigma but p ~ 1e-3."""
    M, n, K = (np.asarray(x, dtype=np.int64) for x in (Ng, kg, N))
    lo = hypergeom.cdf(k, M, n, K)
    hi = hypergeom.sf(k - 1, M, n, K)
    return np.minimum(1.0, 2.0 * np.minimum(lo, hi))


def check_count_repeats(df: pd.DataFrame, keys, counts, file, what: str,
                        z_max: float = COUNT_Z_MAX) -> None:
    """Refuse repeated rows of one point (the same ``keys``) whose counts contradict
    binomial noise.

    Each row's count of each count column is tested against the point's other rows by
    the exact conditional test (the row's count given the point's total is
    hypergeometric when the rows share one probability, :func:`_conditional_p`).  The
    smallest p-value, times the number of rows and columns tested (Bonferroni: one
    table is one decision), below the two-sided normal tail of ``z_max`` refuses the
    rows, naming them, the point and the count, with that p-value as normal sigma.
    Rows with different shots are fine.
    """
    gid = df.groupby(list(keys), sort=False).ngroup().to_numpy()
    n = np.bincount(gid)[gid]
    rep = n > 1
    if not rep.any():
        return
    N = df["shots"].to_numpy(dtype=np.int64)
    Ng = np.bincount(gid, N).astype(np.int64)[gid]
    worst = (1.0, None, None)
    for c in counts:
        k = df[c].to_numpy(dtype=np.int64)
        kg = np.bincount(gid, k).astype(np.int64)[gid]
        p = np.where(rep, _conditional_p(k, kg, N, Ng), 1.0)
        i = int(np.argmin(p))
        if p[i] < worst[0]:
            worst = (float(p[i]), i, c)
    p, i, c = worst
    p = min(1.0, p * int(rep.sum()) * len(counts))
    if not p < 2 * norm.sf(z_max):
        return
    z = float(norm.isf(p / 2)) if p > 0 else math.inf
    same = np.flatnonzero(gid == gid[i])
    point = ", ".join(f"{k}={_plain(df[k].iloc[i])}" for k in keys)
    vals = ", ".join(f"{int(df[c].iloc[j])}/{int(df['shots'].iloc[j])}" for j in same[:6])
    rows = _rows_text(file, [int(j) + 1 for j in same[:6]])
    far = f"{z:.1f} sigma" if math.isfinite(z) else "more than 37 sigma"
    raise InputError(f"repeated {what} {point} in {rows}{' ...' if same.size > 6 else ''} "
                     f"contradict binomial noise: {c} {vals}; row {i + 1} "
                     f"({int(df[c].iloc[i])}/{int(df['shots'].iloc[i])}) {far} from the "
                     "others (exact test, over all repeated rows)", file=file, column=c,
                     row=i + 1)


def read_time_scans(path: str | os.PathLike, *, within=None) -> pd.DataFrame:
    """Read, validate and pool a time-scan file ``A, dpd, t_us, n00, n11, shots``
    (+ ``n01_10``).

    Counts are non-negative integers, ``shots >= 1``, ``n00 + n01_10 + n11 == shots``
    (without ``n01_10``: ``n00 + n11 <= shots``), ``t_us >= 0``.  A point ``(A, dpd,
    t_us)`` recorded again (a repeated time scan, or a repeated point) is a further row:
    the rows of a point are pooled, their counts and shots summed (``n_repeats`` counts
    them), unless their counts contradict binomial noise (:func:`check_count_repeats`).
    ``within``: the folder the file must lie in (a campaign folder,
    :func:`~dpdfit.recordings.tables.read_csv_strings`).

    Returns
    -------
    pandas.DataFrame
        One row per point in order of its first row (the index is that row's 0-based
        data row), ``dpd`` int, ``t_s`` the time in seconds, ``n_repeats``.
    """
    name = str(path)
    ts = read_table(path, *(list(c) for c in CAMPAIGN_TABLES["time_scans"]),
                    ranges={"A": (0, 1), "dpd": (0, 1)}, within=within)
    counts = ["n00", "n11", "shots"] + (["n01_10"] if "n01_10" in ts.columns else [])
    for c in counts:
        v = ts[c].to_numpy()
        few = (v < 1) if c == "shots" else np.zeros(v.shape, dtype=bool)
        bad = few | (v < 0) | (v != np.round(v))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            if few[i]:
                raise ImplausibleValueError(shots_below_one(v[i]), file=name, column=c,
                                            row=i + 1)
            raise InputError(f"count {v[i]:g}: must be a non-negative integer", file=name,
                             column=c, row=i + 1)
    if "n01_10" in ts.columns:
        tot = ts["n00"] + ts["n01_10"] + ts["n11"]
        bad = (tot != ts["shots"]).to_numpy()
        what = "does not equal"
    else:
        tot = ts["n00"] + ts["n11"]
        bad = (tot > ts["shots"]).to_numpy()
        what = "exceeds"
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"counts sum to {tot.iloc[i]:g}, which {what} shots = "
                         f"{ts['shots'].iloc[i]:g}", file=name, column="shots", row=i + 1)
    bad = (ts["t_us"] < 0).to_numpy()
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError("time must be >= 0", file=name, column="t_us", row=i + 1)
    ts["dpd"] = ts["dpd"].astype(int)
    keys = ["A", "dpd", "t_us"]
    outcomes = [c for c in ("n00", "n01_10", "n11") if c in ts.columns]
    check_count_repeats(ts, keys, outcomes, name, "time-scan point")
    ts = _pooled_counts(ts, keys, outcomes + ["shots"])
    ts["t_s"] = ts["t_us"] * 1e-6
    ts.attrs["source"] = name
    return ts


def _pooled_counts(df: pd.DataFrame, keys, counts) -> pd.DataFrame:
    """One row per ``keys``: ``counts`` summed, ``n_repeats`` rows pooled, the other
    columns of the first row; index the first row's (a table without repeats comes back
    as it was, plus ``n_repeats`` 1)."""
    g = df.groupby(list(keys), sort=False)
    n = g[counts[0]].transform("size").to_numpy()
    if (n == 1).all():
        return df.assign(n_repeats=1)
    first = ~df.duplicated(list(keys)).to_numpy()
    out = df[first].copy()
    sums = g[list(counts)].sum()
    out[list(counts)] = sums.to_numpy().astype(df[counts].to_numpy().dtype)
    out["n_repeats"] = g.size().to_numpy()
    return out
