"""Count-level pooling of repeated scans per setting ``(A, dpd)`` (Supplement S7.4).

Populations: ``n_even`` and ``shots`` are summed per setting ``(A, dpd)``
over scans (exact for any shot numbers; the raw counts are used, not
``round(F N)``).  Parity: phases are rounded to a common grid of 0.01 rad
(``m = round(phi / grid)``) and counts at the same grid point are summed;
the merged point sits at the shot-weighted mean of its raw phases (within
``grid/2`` of the grid point, which is reported as ``phase_grid``).  The
merged parity table is for tables and plots: :func:`~.gates.gate_fidelities`
fits the exact likelihood of every recorded phase, so scans whose phases
jitter around a common set are pooled exactly and never refused.  Phases are
compared as given (no wrapping modulo pi or 2 pi).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from dpdfit.errors import InputError
from dpdfit.recordings.counts import PHASE_GRID_RAD, check_counts, grid_keys
from dpdfit.recordings.tables import table_source

__all__ = ["pool_populations", "merge_parity"]


def _require(df, cols, what):
    for c in cols:
        if c not in df.columns:
            raise InputError(f"{what}: required column is missing", file=table_source(df),
                             column=c)


def _check_frame(df, counts, extra_finite=()):
    """Validate a DataFrame built in Python like a file: counts, shots, dpd, finite A.

    Rows are reported as the DataFrame's position + 1 (= the data row of a
    file read by :func:`read_populations` / :func:`read_parity`).
    """
    file = table_source(df)
    for c in ["A", *extra_finite]:
        arr = pd.to_numeric(df[c], errors="coerce").to_numpy(dtype=float)
        bad = ~np.isfinite(arr)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"value {df[c].iloc[i]!r} is not a finite number", file=file,
                             column=c, row=i + 1)
    check_counts(df, [*counts, "shots"], file)
    arr = pd.to_numeric(df["dpd"], errors="coerce").to_numpy(dtype=float)
    bad = (arr != 0) & (arr != 1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"dpd = {df['dpd'].iloc[i]!r} must be 0 or 1", file=file, column="dpd",
                         row=i + 1)


def pool_populations(df: pd.DataFrame) -> pd.DataFrame:
    """Count-level pooling of population scans per setting ``(A, dpd)`` (S7.4).

    Sums ``n_even`` and ``shots`` (and ``n00``, ``n01_10``, ``n11`` when
    present; ``n_even = n00 + n11`` when only those are given) over the
    scans of each setting -- exact for any shot numbers.  Counts are
    validated as in :func:`read_populations` (rows = position + 1).

    Returns
    -------
    pandas.DataFrame
        Columns ``A, dpd, n_even, shots, n_scans`` (+ summed ``n00``,
        ``n01_10``, ``n11``), one row per setting, sorted by ``dpd`` then ``A``.
    """
    if "n_even" not in df.columns and all(c in df.columns for c in ("n00", "n01_10", "n11")):
        src_name = table_source(df)
        df = df.assign(n_even=df["n00"] + df["n11"])
        df.attrs["source"] = src_name
    _require(df, ["A", "dpd", "n_even", "shots"], "populations")
    if len(df) == 0:
        raise InputError("populations table has no rows", file=table_source(df))
    _check_frame(df, ["n_even"] + [c for c in ("n00", "n01_10", "n11") if c in df.columns])
    extra = [c for c in ("n00", "n01_10", "n11") if c in df.columns]
    agg = {"n_even": ("n_even", "sum"), "shots": ("shots", "sum")}
    agg.update({c: (c, "sum") for c in extra})
    if "scan" in df.columns:
        agg["n_scans"] = ("scan", "nunique")
    else:
        agg["n_scans"] = ("n_even", "size")
    out = df.groupby(["A", "dpd"], sort=True).agg(**agg).reset_index()
    for c in ["n_even", "shots", *extra, "n_scans"]:
        out[c] = out[c].astype(np.int64)
    out["dpd"] = out["dpd"].astype(np.int64)
    return out.sort_values(["dpd", "A"], kind="stable").reset_index(drop=True)


def merge_parity(df: pd.DataFrame, grid: float = PHASE_GRID_RAD) -> pd.DataFrame:
    """Merge repeated parity scans at the count level (S7.4).

    Phases are rounded to a common grid (``round(phi / grid)``, default
    0.01 rad) and counts at the same grid point of the same setting
    ``(A, dpd)`` are summed.  This merged table is for tables and plots:
    :func:`gate_fidelities` fits the exact likelihood of every recorded phase
    instead, so scans whose phases jitter around a common set (each scan's
    own analysis-phase offset, recorded as is) are never refused.

    Returns
    -------
    pandas.DataFrame
        ``A, dpd, phase_rad, phase_grid, n_even, shots, n_scans``:
        ``phase_grid`` is the grid point, ``phase_rad`` the shot-weighted
        mean of the merged raw phases (within ``grid/2`` of it), which is
        what :func:`gate_fidelities` fits.  Sorted by dpd, A, phase.
    """
    _require(df, ["A", "dpd", "phase_rad", "n_even", "shots"], "parity")
    if len(df) == 0:
        raise InputError("parity table has no rows", file=table_source(df))
    _check_frame(df, ["n_even"], extra_finite=["phase_rad"])
    grid = float(grid)
    if not grid > 0:
        raise InputError(f"phase grid {grid:g} must be > 0")
    work = pd.DataFrame({
        "A": df["A"].to_numpy(dtype=float), "dpd": df["dpd"].to_numpy(),
        "scan": (df["scan"].astype(str).to_numpy() if "scan" in df.columns
                 else np.full(len(df), "1")),
        "phase_rad": df["phase_rad"].to_numpy(dtype=float),
        "n_even": df["n_even"].to_numpy(dtype=float), "shots": df["shots"].to_numpy(dtype=float)})
    work["key"] = grid_keys(work["phase_rad"], grid)
    work["wphase"] = work["phase_rad"] * work["shots"]
    out = work.groupby(["A", "dpd", "key"], sort=True).agg(
        wphase=("wphase", "sum"), n_even=("n_even", "sum"), shots=("shots", "sum"),
        n_scans=("scan", "nunique")).reset_index()
    out["phase_rad"] = out["wphase"] / out["shots"]
    out["phase_grid"] = out["key"] * grid
    out["n_even"] = out["n_even"].astype(np.int64)
    out["shots"] = out["shots"].astype(np.int64)
    out["dpd"] = out["dpd"].astype(np.int64)
    out = out[["A", "dpd", "phase_rad", "phase_grid", "n_even", "shots", "n_scans"]]
    return out.sort_values(["dpd", "A", "phase_grid"], kind="stable").reset_index(drop=True)
