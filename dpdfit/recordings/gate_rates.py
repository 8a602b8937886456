"""``gate_rates.csv``: the calibrated gate rate of each setting, read by one set of rules.

The campaign folder, the budget (``dpdfit budget --gate-rates``), ``dpdfit fidelity
--gate-rates`` and the pipeline read gate rates through :func:`read_gate_rates`, which
returns one row per setting ``(A, dpd)``: a setting calibrated several times (repeated
rows of the same ``A, dpd``) is pooled there, so every consumer sees the same rate.
"""

from __future__ import annotations

import os

import numpy as np
import pandas as pd

from dpdfit.errors import InputError, data_line

from .columns import CAMPAIGN_TABLES
from .repeats import z_limit
from .tables import read_table

__all__ = ["read_gate_rates", "pool_gate_rates", "check_rate_repeats", "MIN_GATE_RATE_KHZ",
           "RATE_Z_MAX"]

#: a rate below this (kHz) is no gate rate: its gate time 1/xi0 overflows (e.g. 1e-320)
MIN_GATE_RATE_KHZ = 1e-6
#: repeated calibrations of a setting this many standard deviations apart contradict
RATE_Z_MAX = 6.0
_SETTING = ["A", "dpd"]


def read_gate_rates(path: str | os.PathLike, *, within=None) -> pd.DataFrame:
    """``A, dpd, xi0_khz`` (+ ``xi0_err_khz``), one row per setting, validated and pooled.

    A in [0, 1], dpd 0 or 1 (returned as int), ``xi0_khz`` and ``xi0_err_khz`` > 0, no
    rate below :data:`MIN_GATE_RATE_KHZ`, no line copied in every column (a line pasted
    twice: a repeated calibration reads differently), repeated calibrations of a setting
    consistent (:func:`check_rate_repeats`); an :class:`~dpdfit.errors.InputError` names
    file, column and row.  Repeated rows of a setting are pooled
    (:func:`pool_gate_rates`); the index is the 0-based data row of each setting's first
    row, and ``n_repeats`` counts its calibrations.
    ``within``: the folder the file must lie in (a campaign folder,
    :func:`~dpdfit.recordings.tables.read_csv_strings`).
    """
    name = str(path)
    required, optional = CAMPAIGN_TABLES["gate_rates"]
    df = read_table(path, list(required), list(optional),
                    ranges={"A": (0.0, 1.0), "dpd": (0, 1)},
                    positive=["xi0_khz", "xi0_err_khz"], within=within)
    v = df["dpd"].to_numpy()
    bad = v != np.round(v)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"dpd = {v[i]:g} must be 0 or 1", file=name, column="dpd", row=i + 1)
    long = df["xi0_khz"].to_numpy() < MIN_GATE_RATE_KHZ
    if long.any():
        i = int(np.flatnonzero(long)[0])
        raise InputError(f"xi0_khz = {df['xi0_khz'].iloc[i]:g} gives a gate time 1/xi0 above "
                         f"{1e3 / MIN_GATE_RATE_KHZ:g} us: not a gate rate", file=name,
                         column="xi0_khz", row=i + 1)
    df["dpd"] = df["dpd"].astype(int)
    _check_pasted(df, name)
    check_rate_repeats(df, name)
    out = pool_gate_rates(df)
    out.attrs["source"] = name
    return out


def _row_ref(name, row: int) -> str:
    line = data_line(name, row) if name is not None else None
    return f"row {row}" + (f" (line {line})" if line is not None else "")


def _check_pasted(df: pd.DataFrame, name: str) -> None:
    """A row equal in every column to an earlier one: refused as a duplicated line."""
    dup = df.duplicated(keep="first").to_numpy()
    if not dup.any():
        return
    j = int(np.flatnonzero(dup)[0])
    i = int(np.flatnonzero((df == df.iloc[j]).all(axis=1).to_numpy())[0])
    raise InputError(f"A={df['A'].iloc[j]:g}, dpd={int(df['dpd'].iloc[j])} repeats "
                     f"{_row_ref(name, i + 1)} in every column: a duplicated line? (a "
                     "repeated calibration of a setting reads differently)", file=name,
                     column="xi0_khz", row=j + 1)


def check_rate_repeats(df: pd.DataFrame, name: str | None = None,
                       z_max: float = RATE_Z_MAX) -> None:
    """Refuse repeated calibrations of a setting whose rates contradict each other.

    With ``xi0_err_khz`` each rate is judged against the inverse-variance weighted mean
    of its setting: ``|x - mean| / sqrt(err^2 - 1/sum(1/err^2))`` (its exact standard
    deviation) beyond ``z_max``.  Without stated errors, in ``ln xi0`` (a rate's
    calibration error is relative) against a robust scale from all repeated settings'
    scatter, beyond :func:`~.repeats.z_limit` (the same false-alarm probability for a
    scale estimated from the repeats; with few repeats nothing is refused).
    """
    g = df.groupby(_SETTING, sort=False)
    n = g["xi0_khz"].transform("size").to_numpy()
    if not (n > 1).any():
        return
    x = df["xi0_khz"].to_numpy(dtype=float)
    if "xi0_err_khz" in df.columns:
        w = 1 / df["xi0_err_khz"].to_numpy(dtype=float) ** 2
        sw = pd.Series(w).groupby(g.ngroup().to_numpy()).transform("sum").to_numpy()
        mean = pd.Series(w * x).groupby(g.ngroup().to_numpy()).transform("sum").to_numpy() / sw
        sd = np.sqrt(np.maximum(1 / w - 1 / sw, 1e-300))
        z = np.where(n > 1, np.abs(x - mean) / sd, 0.0)
        limit, scale = z_max, "their stated errors xi0_err_khz"
    else:
        lx = np.log(x)
        r = lx - pd.Series(lx).groupby(g.ngroup().to_numpy()).transform("mean").to_numpy()
        f = np.sqrt(np.where(n > 1, 1 - 1 / n, 1.0))
        rep = n > 1
        s = 1.4826 * float(np.median(np.abs(r[rep]) / f[rep]))
        z = np.where(rep, np.abs(r) / (f * max(s, 1e-12)), 0.0)
        limit = z_limit(float(np.sum(1 - 1 / n[rep])), z_max)
        scale = f"the repeated settings' scatter, {100 * s:.3g} %"
    if not z.max() > limit:
        return
    j = int(np.argmax(z))
    same = np.flatnonzero((g.ngroup() == g.ngroup().iloc[j]).to_numpy())
    raise InputError(
        f"repeated calibrations of A={df['A'].iloc[j]:g}, dpd={int(df['dpd'].iloc[j])} in "
        f"rows {', '.join(str(i + 1) for i in same)} contradict each other: xi0_khz "
        f"{', '.join(f'{x[i]:.6g}' for i in same)}, row {j + 1} {z[j]:.1f} sigma from the "
        f"others (by {scale})", file=name, column="xi0_khz", row=j + 1)


def pool_gate_rates(df: pd.DataFrame) -> pd.DataFrame:
    """One row per setting ``(A, dpd)``: its repeated calibrations pooled.

    With ``xi0_err_khz``: the inverse-variance weighted mean and its error
    ``1/sqrt(sum 1/err^2)``.  Without: the plain mean, and ``xi0_sem_khz``, the standard
    error of a repeated setting's mean (NaN for one calibration; informational: the
    file states no error for a single calibration, so none is invented for the pooled
    ones).  ``n_repeats`` counts the calibrations.  Settings in order of their first row,
    the index that row's; a setting calibrated once keeps its values to the last bit.
    """
    key = df.groupby(_SETTING, sort=False).ngroup().to_numpy()
    first = np.unique(key, return_index=True)[1]
    out = df.iloc[first][_SETTING].copy()
    x = df["xi0_khz"].to_numpy(dtype=float)
    n = np.bincount(key).astype(int)
    once = n == 1
    if "xi0_err_khz" in df.columns:
        err = df["xi0_err_khz"].to_numpy(dtype=float)
        w = 1 / err ** 2
        sw = np.bincount(key, w)
        out["xi0_khz"] = np.where(once, x[first], np.bincount(key, w * x) / sw)
        out["xi0_err_khz"] = np.where(once, err[first], 1 / np.sqrt(sw))
    else:
        mean = np.bincount(key, x) / n
        out["xi0_khz"] = np.where(once, x[first], mean)
        if not once.all():
            ss = np.bincount(key, (x - mean[key]) ** 2)
            with np.errstate(invalid="ignore", divide="ignore"):
                out["xi0_sem_khz"] = np.where(once, np.nan, np.sqrt(ss / (n - 1) / n))
    out["n_repeats"] = n
    out.attrs.update(df.attrs)
    return out
