"""``spectra.csv``: recorded tone powers, their repeated recordings and how those are pooled.

A lab that records the spectrum of one setting ``(A, dpd)`` several times has several
*repeat traces* of each ``(A, dpd, sideband)``, and so several rows of each tone
``(A, dpd, sideband, n)``.  :func:`read_spectra` reads every row (one per reading) and
labels its repeat (column ``repeat``): the file's own optional ``repeat`` column when it
has one, else the occurrence number of the tone, so that the k-th row of a tone belongs
to the k-th repeat trace (a repeat is appended as a whole trace, its rows in file order).

:func:`pool_spectra` pools the repeats of each tone as repeated readings of one power
are pooled: the mean of the *linear* powers.  A reading is ``|c + n|^2`` with complex
noise of mean power ``N0``, so ``E = |c|^2 + N0`` for every reading, and their mean keeps
that expectation (a reading below the floor included: it is an honest reading, and
leaving it out would bias the mean up); the floor's debiasing of the diagnosis stays
valid, and every error that comes from independent repeats shrinks as ``1/sqrt(k)``.

Bad input refused, in one line naming the file, rows and tone:

* the same tone twice in one repeat (with a ``repeat`` column), or, without one, a
  repeat whose rows all copy one earlier repeat of the same trace in every column (a line
  or a trace pasted twice; an honest repeat never reads every tone of a trace to the
  last digit again, though single readings written to 0.001 dB often coincide);
* repeated readings of a tone that contradict each other beyond their noise
  (:func:`check_spectra_repeats`).
"""

from __future__ import annotations

import os

import numpy as np
import pandas as pd
from scipy.optimize import brentq

from dpdfit.errors import InputError, data_line

from .columns import CAMPAIGN_TABLES
from .repeats import z_limit
from .tables import read_table

__all__ = ["TONE_KEY", "TRACE_KEY", "JUDGED_SNR_DB", "REFERENCE_SNR_DB", "FLOOR_MARGIN_DB",
           "MIN_REPEAT_NOISE_DB", "Z_MAX",
           "read_spectra", "pool_spectra", "check_spectra_repeats"]

#: the columns that name a tone, and a trace (the tones of one spectrum of one sideband)
TONE_KEY = ["A", "dpd", "sideband", "n"]
TRACE_KEY = ["A", "dpd", "sideband"]
#: repeated readings are judged only this far above the (median) noise floor, where the
#: reading's noise in dB is Gaussian enough for a 6-sigma rule (a Rician reading at 30 dB
#: leaves its mean by 6 of its sigmas with probability ~1e-7)
JUDGED_SNR_DB = 30.0
#: tones this far above the floor are the reference of a repeat's jitter and of the
#: repeatability: the floor's part of their noise is below 0.02 dB
REFERENCE_SNR_DB = 50.0
#: without ``snr_db``: the floor is bounded from above by the median of the file's weakest
#: 5 % of readings plus this (dB): pure-noise readings' 2.5 % quantile lies 14.4 dB below
#: their median
FLOOR_MARGIN_DB = 15.0
#: the repeatability a judgement assumes at least (dB): the floor's part of the noise of
#: a tone 50 dB above it (0.023 dB), which a floor that is only bounded cannot give
MIN_REPEAT_NOISE_DB = 0.025
#: a reading this many standard deviations from its repeats contradicts them
Z_MAX = 6.0
_DB = 10 / np.log(10)


def read_spectra(path: str | os.PathLike, *, within=None) -> pd.DataFrame:
    """Every reading of ``spectra.csv``, validated, with its repeat label.

    Columns ``A, dpd, sideband, n, P_dB, valid`` (``valid`` 1 when the file has none),
    ``repeat`` (text: the file's column, else the tone's occurrence number ``"1"``,
    ``"2"``, ...) and ``snr_db`` when recorded; one row per data row, in file order
    (the index is the 0-based data row).  Refused (InputError naming file, column,
    rows and tone): a sideband other than red/blue, a non-integer ``dpd`` or ``n``,
    a tone twice in one repeat or a repeat that copies an earlier one, repeated
    readings that contradict each other (module doc).
    ``within``: the folder the file must lie in (a campaign folder,
    :func:`~dpdfit.recordings.tables.read_csv_strings`).
    """
    name = str(path)
    required, optional = (list(c) for c in CAMPAIGN_TABLES["spectra"])
    df = read_table(path, required, optional, numeric=["A", "dpd", "n", "P_dB"],
                    ranges={"A": (0, 1), "dpd": (0, 1)}, within=within)
    bad = ~df["sideband"].isin(["red", "blue"])
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        raise InputError(f"sideband must be red or blue, got '{df['sideband'].iloc[i]}'",
                         file=name, column="sideband", row=i + 1)
    for col in ("dpd", "n"):
        v = df[col].to_numpy()
        bad = v != np.round(v)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"{col} = {v[i]:g} must be an integer", file=name, column=col,
                             row=i + 1)
    df["dpd"] = df["dpd"].astype(int)
    df["n"] = df["n"].astype(int)
    if "valid" in df.columns:      # a flag that is not a finite number: not valid (0)
        v = pd.to_numeric(df["valid"], errors="coerce")
        df["valid"] = v.where(np.isfinite(v), 0).astype(int)
    else:
        df["valid"] = 1
    if "snr_db" in df.columns:
        df["snr_db"] = pd.to_numeric(df["snr_db"], errors="coerce")
    if "repeat" in df.columns:
        _check_repeat_labels(df, name)
    else:
        _check_no_repeat_copied(df, name)
        df["repeat"] = (df.groupby(TONE_KEY, sort=False).cumcount() + 1).astype(str)
    check_spectra_repeats(df, name)
    df.attrs["source"] = name
    return df


def _tone_label(row) -> str:
    return f"tone (A={row['A']:g}, dpd={int(row['dpd'])}, {row['sideband']}, n={int(row['n'])})"


def _rows_text(name: str, rows, most: int = 6) -> str:
    """``"rows 5, 790 (lines 6, 791)"``: 1-based data rows, the first ``most`` of them."""
    rows = [int(r) for r in rows]
    shown = rows[:most]
    more = f", ... ({len(rows)} rows)" if len(rows) > most else ""
    lines = [data_line(name, r) for r in shown] if name is not None else [None]
    one = len(rows) == 1
    text = f"row{'' if one else 's'} {', '.join(map(str, shown))}{more}"
    if None in lines:
        return text
    return text + f" (line{'' if one else 's'} {', '.join(map(str, lines))}" \
                  f"{', ...' if more else ''})"


def _check_repeat_labels(df: pd.DataFrame, name: str) -> None:
    """A ``repeat`` column: non-empty labels, no tone twice in one repeat."""
    df["repeat"] = df["repeat"].astype(str)
    empty = (df["repeat"] == "").to_numpy()
    if empty.any():
        i = int(np.flatnonzero(empty)[0])
        raise InputError("repeat label is empty", file=name, column="repeat", row=i + 1)
    dup = df.duplicated(TONE_KEY + ["repeat"], keep=False).to_numpy()
    if dup.any():
        first = df.iloc[int(np.flatnonzero(dup)[0])]
        same = np.flatnonzero(dup & (df[TONE_KEY + ["repeat"]] == first[TONE_KEY + ["repeat"]])
                              .all(axis=1).to_numpy()) + 1
        raise InputError(f"{_tone_label(first)} appears twice in repeat {first['repeat']} "
                         f"({_rows_text(name, same)}): a duplicated line?", file=name,
                         column="repeat", row=int(same[1]))


def _check_no_repeat_copied(df: pd.DataFrame, name: str) -> None:
    """Without a ``repeat`` column: no repeat trace that copies one earlier repeat of the
    same trace, every row equal in every column to that repeat's row of the same tone (a
    line or a trace pasted twice).

    Readings written to 0.001 dB coincide now and then, and over many repeats a trace's
    every reading may equal *some* earlier reading, each from a different repeat; that is
    honest.  A copy is one earlier repeat read again to the last digit, whole.
    """
    rep = df.groupby(TONE_KEY, sort=False).cumcount().to_numpy()
    if not (rep > 0).any():
        return
    dup = df.duplicated(keep="first").to_numpy()
    if not dup.any():
        return
    trace = df.groupby(TRACE_KEY, sort=False).ngroup().to_numpy()
    # a repeat can copy an earlier one only if each of its rows equals an earlier row;
    # only those few repeats are examined one by one
    maybe = pd.Series(dup).groupby([trace, rep]).transform("all").to_numpy() & (rep > 0)
    if not maybe.any():
        return
    # the class of equal rows of each row, and the repeats each class holds
    same = df.groupby(list(df.columns), sort=False, dropna=False).ngroup().to_numpy()
    held = pd.DataFrame({"same": same, "rep": rep, "row": np.arange(len(df))})
    first_of = held.drop_duplicates(["same", "rep"]).set_index(["same", "rep"])["row"]
    for t, k in pd.DataFrame({"t": trace[maybe], "k": rep[maybe]}).drop_duplicates() \
            .itertuples(index=False):
        rows = np.flatnonzero((trace == t) & (rep == k))
        for r in sorted(held.loc[held["same"] == same[rows[0]], "rep"].unique()):
            if r >= k:
                break
            keys = list(zip(same[rows].tolist(), [int(r)] * rows.size))
            if all(key in first_of.index for key in keys):
                _refuse_copy(df, name, rows, first_of.loc[keys].to_numpy(), int(r))


def _refuse_copy(df: pd.DataFrame, name: str, rows, originals, r: int) -> None:
    first = df.iloc[int(rows[0])]
    what = "a line pasted twice" if rows.size == 1 else "a trace pasted twice"
    raise InputError(f"{_rows_text(name, rows + 1)} of trace (A={first['A']:g}, "
                     f"dpd={int(first['dpd'])}, {first['sideband']}) "
                     f"{'copies' if rows.size == 1 else 'copy'} "
                     f"{_rows_text(name, np.asarray(originals) + 1)} (its repeat {r + 1}) in "
                     f"every column: {what}? (a repeated recording reads differently)",
                     file=name, row=int(rows[0]) + 1)


def _floor_db(df: pd.DataFrame) -> np.ndarray:
    """Median noise power (dB) under each reading: the recorded ``P_dB - snr_db``, else a
    bound from above for the whole file: the median of its weakest 5 % of readings plus
    :data:`FLOOR_MARGIN_DB` (readings of pure noise are exponential in power, so their
    weakest lie up to 14.4 dB below their median; readings with a tone lie higher), which
    only ever makes the judgement more lenient."""
    P = df["P_dB"].to_numpy(dtype=float)
    k = max(1, int(np.ceil(0.05 * P.size)))
    bound = float(np.median(np.partition(P, k - 1)[:k])) + FLOOR_MARGIN_DB
    if "snr_db" not in df.columns:
        return np.full(P.size, bound)
    f = P - df["snr_db"].to_numpy(dtype=float)
    return np.where(np.isfinite(f), f, bound)


def check_spectra_repeats(df: pd.DataFrame, name: str | None = None,
                          z_max: float = Z_MAX) -> None:
    """Refuse repeated readings of a tone that contradict each other beyond their noise.

    Repeats of one trace differ by the laser-power jitter of each repeat (common to its
    tones, often dB) and by each tone's own noise; the jitter cancels in ratios within a
    repeat.  So each trace's readings are judged as a table, tones x repeats, of dB
    values: the tones read in every repeat, each at least :data:`JUDGED_SNR_DB` above
    the floor in every repeat (``snr_db``, else a bound from above, :func:`_floor_db`).
    A repeat's jitter is the mean deviation of its *reference* tones, those at least
    :data:`REFERENCE_SNR_DB` above the floor (all judged tones of a trace that has
    none); removing it and each tone's mean leaves the residuals ``e``.  With
    independent readings of variance ``s^2 + v`` (``v`` the floor's part
    ``(10/ln 10)^2 2 N0 / P``; where the floor is only bounded, too large, which makes
    the rule more lenient, and 0 for the reference tones) the variance of ``e`` follows
    exactly.  Each trace is judged by the repeatability ``s`` learnt from the *other*
    traces (their mean ``e^2`` over its variance is 1; at least
    :data:`MIN_REPEAT_NOISE_DB`; from the reference tones only where the floor is
    bounded): a residual beyond ``z_max`` of its standard deviations -- beyond
    :func:`~.repeats.z_limit`, the Student-t threshold with the same false-alarm
    probability for a scale from that many degrees of freedom -- is refused, naming the
    tone, its rows and the row.  A contradiction among tones nearer the floor, or of a
    trace's single judged tone, is not seen by this rule; honest repeats (0.05 dB
    repeatability, 2 dB jitter, Rician floor noise) stay below 0.8 of the threshold in
    1,400 simulated files.
    """
    if not df.duplicated(TONE_KEY).any():
        return
    P = df["P_dB"].to_numpy(dtype=float)
    floor = _floor_db(df)
    N0 = 10 ** (floor / 10) / np.log(2)
    d = pd.DataFrame({**{c: df[c].to_numpy() for c in TRACE_KEY + ["n", "repeat"]},
                      "P": P, "snr": P - floor, "row": np.arange(len(df)),
                      "v": _DB ** 2 * 2 * N0 / np.maximum(10 ** (P / 10) - N0, 1e-300)})
    tone = d.groupby(TONE_KEY, sort=False)
    n_rep = d.groupby(TRACE_KEY, sort=False)["repeat"].transform("nunique")
    low = tone["snr"].transform("min")
    d = d[((tone["P"].transform("size") == n_rep) & (n_rep > 1)
           & (low >= JUDGED_SNR_DB)).to_numpy()].copy()
    if len(d) < 4:
        return
    known = "snr_db" in df.columns and bool(np.isfinite(df["snr_db"]).all())
    e, a, b, w, fit, tid = _residuals(d, known)
    z, dof, s = _deleted_z(e, a, b, w, fit, tid)
    limit = np.array([z_limit(x, z_max, efficiency=1.0) for x in dof])[tid]
    worst = int(np.argmax(z / limit))
    if not z[worst] > limit[worst]:
        return
    s = s[tid[worst]]
    i = int(d["row"].iloc[worst])
    row = df.iloc[i]
    same = np.flatnonzero((df[TONE_KEY] == row[TONE_KEY]).all(axis=1).to_numpy())
    vals = ", ".join(f"{x:.6g}" for x in P[same][:6])
    raise InputError(
        f"repeated readings of {_tone_label(row)} in {_rows_text(name, same + 1)} "
        f"contradict each other: P_dB {vals}{', ...' if same.size > 6 else ''}; row "
        f"{i + 1}'s ratio to the other tones of its repeat is {z[worst]:.1f} sigma from "
        f"the other repeats' (repeatability {s:.3g} dB): a mistyped or mislabelled row?",
        file=name, column="P_dB", row=i + 1)


def _residuals(d: pd.DataFrame, known: bool):
    """The judged readings ``d`` (:func:`check_spectra_repeats`) as residuals free of
    each repeat's jitter and each tone's mean: ``e``, their variance ``a s^2 + b``, their
    degrees of freedom ``w``, the rows the repeatability is learnt from (``known``: the
    floor is recorded) and each row's trace."""
    trace = [d[c] for c in TRACE_KEY]
    top = d.groupby(TONE_KEY, sort=False)["snr"].transform("min") >= REFERENCE_SNR_DB
    strong = top.groupby(trace, sort=False).transform("any")
    d["ref"] = top | ~strong                     # a trace without one: its judged tones
    top = top.to_numpy()
    tone = d.groupby(TONE_KEY, sort=False)
    k = tone["P"].transform("size").to_numpy(dtype=float)
    dev = d["P"] - tone["P"].transform("mean")
    # a repeat's jitter: the mean deviation of its reference tones
    ref = d["ref"].to_numpy()
    rep_key = trace + [d["repeat"]]
    jit = dev.where(ref).groupby(rep_key, sort=False).transform("mean")
    e = (dev - jit).to_numpy()
    m = d["ref"].astype(float).groupby(rep_key, sort=False).transform("sum").to_numpy()
    # Var e = (1 - 1/k) [(1 - 2/m) V_t + sum_ref V / m^2] for a reference tone, without
    # the -2/m for another (V = s^2 + v): a s^2 + b
    vt = tone["v"].transform("mean").to_numpy()
    if not known:
        # a floor bounded from above overstates the floor part of the tones 50 dB above
        # it; it is below MIN_REPEAT_NOISE_DB for them
        vt = np.where(top, 0.0, vt)
    vref = pd.Series(np.where(ref, vt / k, 0.0)).groupby(
        [np.asarray(c) for c in trace], sort=False).transform("sum").to_numpy()
    own = np.where(ref, 1 - 2 / m, 1.0)
    a = (1 - 1 / k) * (own + 1 / m)
    b = (1 - 1 / k) * (own * vt + vref / m ** 2)
    # the repeatability is learnt where the noise model holds: every judged tone when
    # the floor is recorded, else the reference tones (a floor bounded from above
    # overstates the others' noise)
    fit = (a > 1e-12) & (np.ones(len(d), bool) if known else top if top.any() else ref)
    w = (1 - 1 / k) * np.where(ref, 1 - 1 / m, 1.0)        # residual degrees of freedom
    tid = d.groupby(TRACE_KEY, sort=False).ngroup().to_numpy()
    return e, a, b, w, fit, tid


def _deleted_z(e, a, b, w, fit, tid):
    """Studentised deleted residuals of each trace: ``|e| / sqrt(a s^2 + b)`` with the
    repeatability ``s`` learnt from the *other* traces' residuals (``fit`` rows), so that
    a contradiction cannot hide by inflating its own scale.  Returns per row ``z``, and
    per trace the degrees of freedom ``sum w`` of its scale and the scale itself."""
    n_tr = int(tid.max()) + 1
    dof, scale = np.zeros(n_tr), np.zeros(n_tr)
    z = np.zeros(e.size)
    for t in range(n_tr):
        rest = fit & (tid != t)
        mine = (tid == t) & (a > 1e-12)
        if not rest.any() or not mine.any():
            continue
        dof[t] = float(np.sum(w[rest]))
        scale[t] = _repeat_scale(e[rest] ** 2, a[rest], b[rest], MIN_REPEAT_NOISE_DB)
        z[mine] = np.abs(e[mine]) / np.sqrt(a[mine] * scale[t] ** 2 + b[mine])
    return z, dof, scale


def _repeat_scale(e2: np.ndarray, a: np.ndarray, b: np.ndarray, lower: float,
                  upper: float = 20.0) -> float:
    """``s >= lower`` with ``mean(e2 / (a s^2 + b)) = 1`` (``lower`` when the floor's noise
    and ``lower`` already explain the scatter)."""
    def g(s):
        return np.mean(e2 / (a * s * s + b)) - 1.0

    if g(lower) <= 0:
        return lower
    if g(upper) > 0:
        return upper
    return float(brentq(g, lower, upper, xtol=1e-6))


def pool_spectra(df: pd.DataFrame) -> pd.DataFrame:
    """One row per tone ``(A, dpd, sideband, n)``, its repeats pooled (module doc).

    * ``P_dB``: ``10 log10`` of the mean linear power of the readings;
    * ``n_repeats``: how many readings were pooled;
    * ``valid``: 1 when any reading is valid -- the tone was seen above the floor, and
      the mean of all its readings (those at the floor included, each an honest
      ``|c + n|^2``) is an unbiased reading of ``|c|^2 + N0``; 0 when none is (the
      pooled power is an upper limit, as each reading is);
    * ``snr_db`` (when recorded): the pooled power over the mean of the readings'
      floors (``N0`` is per trace; the pooled reading's floor is their mean).

    Tones in order of their first reading; ``attrs`` kept.  A table with one reading
    per tone comes back with its values (and ``n_repeats`` 1).
    """
    lin = 10 ** (df["P_dB"].to_numpy(dtype=float) / 10)
    valid = df["valid"].to_numpy() if "valid" in df.columns else np.ones(len(df), dtype=int)
    parts = {"_lin": lin, "valid": valid}
    if "snr_db" in df.columns:
        parts["_floor"] = 10 ** ((df["P_dB"] - df["snr_db"]).to_numpy(dtype=float) / 10)
    work = pd.DataFrame({**{c: df[c].to_numpy() for c in TONE_KEY}, **parts})
    g = work.groupby(TONE_KEY, sort=False)
    out = g.agg(_lin=("_lin", "mean"), valid=("valid", "max"), n_repeats=("_lin", "size"),
                **({"_floor": ("_floor", "mean")} if "snr_db" in df.columns else {}))
    out = out.reset_index()
    # a tone read once keeps its recorded values to the last bit
    once = (out["n_repeats"] == 1).to_numpy()
    first = g.ngroup().to_numpy()
    at = np.full(len(out), -1)
    at[first[::-1]] = np.arange(len(df))[::-1]          # each tone's first row
    out["P_dB"] = np.where(once, df["P_dB"].to_numpy(dtype=float)[at],
                           10 * np.log10(out.pop("_lin")))
    if "snr_db" in df.columns:
        out["snr_db"] = np.where(once, df["snr_db"].to_numpy(dtype=float)[at],
                                 out["P_dB"] - 10 * np.log10(out.pop("_floor")))
    out["valid"] = out["valid"].astype(int)
    cols = TONE_KEY + ["P_dB", "valid"] + (["snr_db"] if "snr_db" in df.columns else []) \
        + ["n_repeats"]
    out = out[cols]
    out.attrs.update(df.attrs)
    return out
