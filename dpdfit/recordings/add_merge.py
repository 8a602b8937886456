"""The rows ``dpdfit add`` appends to one campaign table: columns matched, runs, scans, repeats.

:func:`merge_table` takes a campaign table and NEW's rows of it (text tables,
:mod:`.add_sources`) and returns NEW's rows ready to be appended: calibration runs
already in the campaign skipped (or refused when their rows differ), columns matched
to the campaign's, ``spectra``'s ``repeat`` continued per tone.
:func:`renumber_scans` continues the ``scan`` labels of populations and parity per
setting.  The rules are those of :mod:`.campaign_add`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from dpdfit.errors import InputError

from .add_checks import same_run
from .add_sources import SOURCE_COLUMNS
from .columns import CAMPAIGN_TABLES

__all__ = ["merge_table", "renumber_scans", "continued_labels", "FILLED"]

#: campaign columns NEW may lack: (table, column) -> how its rows are filled
FILLED = {("spectra", "valid"): "1 (valid, as without the column)",
          ("spectra", "snr_db"): "empty (the diagnosis estimates the noise floor)",
          ("spectra", "repeat"): "continued per tone",
          ("populations", "n_even"): "n00 + n11"}
_TONE = ["A", "dpd", "sideband", "n"]


def _int_label(label) -> int | None:
    try:
        x = float(label)
    except (TypeError, ValueError):
        return None
    return int(x) if np.isfinite(x) and x.is_integer() else None


def continued_labels(old_keys, old_labels, new_keys, new_labels) -> list:
    """Labels of new rows continued after the old ones of the same key: a new label ``k``
    of a key whose largest integer label is ``m`` becomes ``m + `` the rank of ``k`` among
    the key's new labels (in numeric order when all are integers, else first appearance);
    rows of one new label keep one label."""
    top = {}
    for key, lab in zip(old_keys, old_labels):
        v = _int_label(lab)
        if v is not None:
            top[key] = max(top.get(key, 0), v)
    seen = {}
    for key, lab in zip(new_keys, new_labels):
        seen.setdefault(key, dict())[lab] = None
    renamed = {}
    for key, labs in seen.items():
        labs = list(labs)
        if all(_int_label(x) is not None for x in labs):
            labs = sorted(labs, key=_int_label)
        for rank, lab in enumerate(labs, 1):
            renamed[(key, lab)] = str(top.get(key, 0) + rank)
    return [renamed[(key, lab)] for key, lab in zip(new_keys, new_labels)]


def _keys(df: pd.DataFrame, cols) -> list:
    """Row keys with numbers as numbers (``0.50`` and ``0.5`` one setting)."""
    def num(v):
        try:
            return float(v)
        except ValueError:
            return v
    return list(zip(*(map(num, df[c]) if c != "sideband" else df[c] for c in cols)))


def renumber_scans(campaign: dict, kept: dict) -> list[str]:
    """Continue the ``scan`` labels of NEW's populations and parity (``kept``, changed in
    place) after the campaign's (``campaign``: its populations and parity text tables or
    None), per setting over both tables; the notes of the settings renumbered."""
    tables = [t for t in ("populations", "parity") if t in kept and not kept[t].empty]
    if not tables:
        return []
    old = [df for df in (campaign.get("populations"), campaign.get("parity"))
           if df is not None and not df.empty and {"A", "dpd", "scan"} <= set(df.columns)]
    old_keys = [k for df in old for k in _keys(df, ["A", "dpd"])]
    old_labels = [x for df in old for x in df["scan"]]
    new_keys = [k for t in tables for k in _keys(kept[t], ["A", "dpd"])]
    new_labels = [x for t in tables for x in kept[t]["scan"]]
    labels = continued_labels(old_keys, old_labels, new_keys, new_labels)
    start, notes = 0, {}
    for t in tables:
        n = len(kept[t])
        kept[t] = kept[t].assign(scan=labels[start:start + n])
        start += n
    for key, a, b in zip(new_keys, new_labels, labels):
        if a != b:
            notes.setdefault(f"A={key[0]:g}, dpd={key[1]:g}", {})[a] = b
    lines = [f"scan labels continued at {s}: " + ", ".join(f"{a} -> {b}" for a, b in m.items())
             for s, m in notes.items()]
    return lines[:6] + ([f"... and {len(lines) - 6} more settings"] if len(lines) > 6 else [])


def merge_table(table: str, mine, theirs: pd.DataFrame, rec, campaign_file: str):
    """NEW's rows of ``table`` ready to be appended to the campaign's ``mine`` (None: the
    campaign has no such table), ``mine`` with NEW's extra columns, and the lines of the
    runs skipped and of the notes: ``(rows, mine, skipped, notes)`` (module doc)."""
    skipped, notes = [], []
    theirs = theirs.copy()
    required, optional = CAMPAIGN_TABLES[table]
    _check_required(required, mine, theirs, rec, table, campaign_file)
    if table.startswith("calibration_"):
        theirs, skipped = _runs(table, mine, theirs, rec, campaign_file)
    if mine is None or theirs.empty:
        return theirs, mine, skipped, notes
    mine = mine.copy()
    had_repeat = "repeat" in theirs.columns
    for c in [c for c in mine.columns if c not in theirs.columns]:
        if table == "populations" and c == "n_even" and {"n00", "n11"} <= set(theirs):
            theirs[c] = _even_counts(theirs, rec)
        elif (table, c) in FILLED:
            theirs[c] = "1" if c == "valid" else ""
        elif c in required or c in optional:
            raise InputError(f"NEW's {table} has no column '{c}', which every row of "
                             f"{campaign_file} has (a reader needs it in every row or in none)",
                             file=_file(rec, table))
        else:
            theirs[c] = ""
    for c in [c for c in theirs.columns if c not in mine.columns]:
        if c in SOURCE_COLUMNS or c not in required + optional:
            mine[c] = ""
        else:
            theirs = theirs.drop(columns=c)
            notes.append(f"NEW's column '{c}' of {table} dropped: {campaign_file} has none (a "
                         "reader needs it in every row or in none)")
    theirs = theirs[list(mine.columns)]
    if table == "spectra" and "repeat" in mine.columns:
        new_labels = (theirs["repeat"].tolist() if had_repeat else
                      (theirs.groupby(_TONE, sort=False).cumcount() + 1).astype(str).tolist())
        theirs["repeat"] = continued_labels(_keys(mine, _TONE), mine["repeat"],
                                            _keys(theirs, _TONE), new_labels)
    return theirs, mine, skipped, notes


def _check_required(required, mine, theirs, rec, table: str, campaign_file: str) -> None:
    """Refuse a table of NEW, or the campaign's, without a column its reader needs in
    every row (the merge labels rows by some of them)."""
    if mine is not None and not mine.empty:
        for c in required:
            if c not in mine.columns:
                raise InputError("required column is missing: rows cannot be added to "
                                 "this table", file=campaign_file, column=c)
    for c in required:
        if c not in theirs.columns and (mine is None or mine.empty):
            raise InputError(f"NEW's {table} has no column '{c}', which its reader needs in "
                             "every row", file=_file(rec, table))


def _even_counts(theirs: pd.DataFrame, rec) -> list:
    """``n_even = n00 + n11`` of NEW's populations rows, as text; an InputError naming
    NEW's file, column and row at a count that is not a whole number."""
    counts = {}
    for c in ("n00", "n11"):
        text = theirs[c]
        x = pd.to_numeric(text, errors="coerce").to_numpy(dtype=float)
        ok = np.isfinite(x) & (x >= 0) & (np.floor(x) == x)
        if not ok.all():
            i = int(np.flatnonzero(~ok)[0])
            value = text.iloc[i]
            why = ("is empty" if value == "" else f"= {value!r} is not a count (a whole "
                   "number of shots, 0 or more)")
            raise InputError(f"{c} {why}: n_even = n00 + n11 is added for the campaign's "
                             "column 'n_even'", column=c,
                             **rec.where("populations", int(theirs.index[i]) + 1))
        counts[c] = x
    return [str(int(v)) for v in counts["n00"] + counts["n11"]]


def _file(rec, table: str) -> str:
    return str(rec.path / f"{table}.csv") if rec.kind == "csv" else str(rec.path)


def _runs(table: str, mine, theirs: pd.DataFrame, rec, campaign_file: str):
    """NEW's calibration rows without the runs the campaign has already (the same rows),
    and the lines saying so; a run label the campaign has with other rows is refused."""
    if "run" not in theirs.columns:
        if mine is None:
            return theirs, []
        raise InputError(f"NEW's {table} has no 'run' column: a further calibration run "
                         "needs a label of its own", file=_file(rec, table))
    if mine is None:
        return theirs, []
    if "run" not in mine.columns:
        raise InputError("has no 'run' column (one run): a further run could not be told "
                         "apart from it; label the campaign's run first", file=campaign_file)
    keep = np.ones(len(theirs), dtype=bool)
    skipped = []
    have = set(mine["run"])
    for label, idx in theirs.groupby("run", sort=False).indices.items():
        if label not in have:
            continue
        ours = mine[mine["run"] == label].reset_index(drop=True)
        why = same_run(ours, theirs.iloc[idx].reset_index(drop=True))
        if why is not None:
            raise InputError(f"run '{label}' exists in {campaign_file} with other data "
                             f"({why}): a run label already taken?", column="run",
                             **rec.where(table, int(idx[0]) + 1))
        keep[idx] = False
        skipped.append(f"{table} run {label} ({len(idx)} rows): in the campaign already, "
                       "with the same rows")
    return theirs[keep], skipped
