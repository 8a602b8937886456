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
from .columns import CAMPAIGN_TABLES, MISSING_LINES

__all__ = ["merge_table", "renumber_scans", "continued_labels", "FILLED"]

#: campaign columns NEW may lack: (table, column) -> how its rows are filled
FILLED = {("spectra", "valid"): "1 (valid, as without the column)",
          ("spectra", "snr_db"): "empty (the diagnosis estimates the noise floor)",
          ("spectra", "repeat"): "continued per tone",
          ("populations", "n_even"): "n00 + n11"}
_TONE = ["A", "dpd", "sideband", "n"]
#: the scans renamed at one setting that the report names
_SHOWN_RENAMES = 8


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
    ids = {}
    old_ids = np.array([ids.setdefault(k, len(ids)) for k in old_keys], dtype=np.int64)
    new_ids = np.array([ids.setdefault(k, len(ids)) for k in new_keys], dtype=np.int64)
    labels, _ = _continued(old_ids, np.asarray(old_labels, dtype=object), new_ids,
                           np.asarray(new_labels, dtype=object))
    return labels.tolist()


def _continued(old_ids, old_labels, new_ids, new_labels):
    """:func:`continued_labels` on arrays: keys as integer ids, labels as text.  Returns
    the new rows' labels (an object array) and, per distinct ``(key, label)`` of the new
    rows in the order they first appear, ``(key id, label, new label)``.

    The rows are grouped in C (pandas); only each scan's ``(key, label)`` is handled in
    Python, so a million rows of a few thousand scans take a fraction of a second."""
    top = {}
    if len(old_ids):
        old = pd.DataFrame({"k": old_ids, "l": old_labels}).drop_duplicates()
        for k, lab in zip(old["k"].tolist(), old["l"].tolist()):
            v = _int_label(lab)
            if v is not None:
                top[k] = max(top.get(k, 0), v)
    new = pd.DataFrame({"k": new_ids, "l": new_labels})
    codes = new.groupby(["k", "l"], sort=False).ngroup().to_numpy()   # first seen: 0, 1, ..
    scans = new.drop_duplicates()                                       # in the same order
    by_key = {}
    for k, lab in zip(scans["k"].tolist(), scans["l"].tolist()):
        by_key.setdefault(k, []).append(lab)
    renamed = {}
    for k, labs in by_key.items():
        ints = [_int_label(x) for x in labs]
        order = (sorted(range(len(labs)), key=ints.__getitem__)
                 if all(v is not None for v in ints) else range(len(labs)))
        for rank, i in enumerate(order, 1):
            renamed[(k, labs[i])] = str(top.get(k, 0) + rank)
    pairs = [(k, lab, renamed[(k, lab)]) for k, lab in zip(scans["k"].tolist(),
                                                          scans["l"].tolist())]
    per_scan = np.array([b for _, _, b in pairs], dtype=object)
    return per_scan[codes], pairs


def _number(v):
    try:
        return float(v)
    except (TypeError, ValueError):
        return v


def _key_ids(frames: list, cols) -> tuple[list, list]:
    """The rows' keys of ``cols`` over several text tables, numbers as numbers (``0.50``
    and ``0.5`` one setting; ``sideband`` as text): per table an array of key ids (shared
    over the tables), and the key (a tuple) of each id.  Each column's distinct values
    are converted once; the rows are grouped in C."""
    sizes = [len(df) for df in frames]
    ids, values = {}, []
    for c in cols:
        col = pd.concat([df[c].astype(object) for df in frames], ignore_index=True)
        codes, distinct = pd.factorize(col, use_na_sentinel=False)
        as_key = pd.Series([v if c == "sideband" else _number(v) for v in distinct],
                           dtype=object)
        merged, keys = pd.factorize(as_key, use_na_sentinel=False)
        ids[c] = merged[codes]
        values.append(list(keys))
    rows = pd.DataFrame(ids)
    key_of_row = rows.groupby(list(cols), sort=False).ngroup().to_numpy()
    keys = [tuple(values[j][v] for j, v in enumerate(r))
            for r in rows.drop_duplicates().itertuples(index=False)]
    return np.split(key_of_row, np.cumsum(sizes)[:-1]), keys


def renumber_scans(campaign: dict, kept: dict) -> list[str]:
    """Continue the ``scan`` labels of NEW's populations and parity (``kept``, changed in
    place) after the campaign's (``campaign``: its populations and parity text tables or
    None), per setting over both tables; the notes of the settings renumbered."""
    tables = [t for t in ("populations", "parity") if t in kept and not kept[t].empty]
    if not tables:
        return []
    old = [df for df in (campaign.get("populations"), campaign.get("parity"))
           if df is not None and not df.empty and {"A", "dpd", "scan"} <= set(df.columns)]
    new = [kept[t] for t in tables]
    ids, keys = _key_ids(old + new, ["A", "dpd"])
    labels, pairs = _continued(
        np.concatenate([np.empty(0, np.int64), *ids[:len(old)]]),
        np.concatenate([np.empty(0, object), *(df["scan"].to_numpy(dtype=object)
                                               for df in old)]),
        np.concatenate(ids[len(old):]),
        np.concatenate([df["scan"].to_numpy(dtype=object) for df in new]))
    start = 0
    for t in tables:
        n = len(kept[t])
        kept[t] = kept[t].assign(scan=labels[start:start + n])
        start += n
    notes = {}
    for k, a, b in pairs:
        if a != b:
            notes.setdefault(f"A={keys[k][0]:g}, dpd={keys[k][1]:g}", {})[a] = b
    lines = [f"scan labels continued at {s}: " + _renames(m) for s, m in notes.items()]
    return lines[:6] + ([f"... and {len(lines) - 6} more settings"] if len(lines) > 6 else [])


def _renames(renamed: dict) -> str:
    """``a -> b, ...`` of a setting's first :data:`_SHOWN_RENAMES` scans renamed, then how
    many more (a million rows added are thousands of scans: the report stays readable)."""
    shown = ", ".join(f"{a} -> {b}" for a, b in list(renamed.items())[:_SHOWN_RENAMES])
    more = len(renamed) - _SHOWN_RENAMES
    return shown + (f", ... and {more} more scans" if more > 0 else "")


def merge_table(table: str, mine, theirs: pd.DataFrame, rec, campaign_file: str):
    """NEW's rows of ``table`` ready to be appended to the campaign's ``mine`` (None: the
    campaign has no such table), ``mine`` with NEW's extra columns, and the lines of the
    runs skipped and of the notes: ``(rows, mine, skipped, notes)`` (module doc)."""
    skipped, notes = [], []
    required, optional = CAMPAIGN_TABLES[table]
    _check_required(required, mine, theirs, rec, table, campaign_file)
    if table.startswith("calibration_"):
        theirs, skipped = _runs(table, mine, theirs, rec, campaign_file)
    if mine is None or theirs.empty:
        return theirs, mine, skipped, notes
    # new frames, never a change in place: NEW's and the campaign's tables stay as read
    # (and, with pandas' copy-on-write, share their columns instead of copying them)
    had_repeat = "repeat" in theirs.columns
    for c in [c for c in mine.columns if c not in theirs.columns]:
        if table == "populations" and c == "n_even" and {"n00", "n11"} <= set(theirs):
            theirs = theirs.assign(n_even=_even_counts(theirs, rec))
        elif (table, c) in FILLED:
            theirs = theirs.assign(**{c: "1" if c == "valid" else ""})
        elif c in required or c in optional:
            raise InputError(f"NEW's {table} has no column '{c}', which every row of "
                             f"{campaign_file} has (a reader needs it in every row or in none)",
                             file=_file(rec, table))
        else:
            theirs = theirs.assign(**{c: ""})
    for c in [c for c in theirs.columns if c not in mine.columns]:
        if c in SOURCE_COLUMNS or c not in required + optional:
            mine = mine.assign(**{c: ""})
        else:
            theirs = theirs.drop(columns=c)
            notes.append(f"NEW's column '{c}' of {table} dropped: {campaign_file} has none (a "
                         "reader needs it in every row or in none)")
    theirs = theirs[list(mine.columns)]
    if table == "spectra" and "repeat" in mine.columns:
        new_labels = (theirs["repeat"].to_numpy(dtype=object) if had_repeat else
                      (theirs.groupby(_TONE, sort=False).cumcount() + 1).astype(str)
                      .to_numpy(dtype=object))
        (old_ids, new_ids), _ = _key_ids([mine, theirs], _TONE)
        labels, _ = _continued(old_ids, mine["repeat"].to_numpy(dtype=object), new_ids,
                               new_labels)
        theirs = theirs.assign(repeat=labels)
    return theirs, mine, skipped, notes


def _check_required(required, mine, theirs, rec, table: str, campaign_file: str) -> None:
    """Refuse a table of NEW, or the campaign's, without a column its reader needs in
    every row (the merge labels rows by some of them).  The campaign's table counts from
    its header: one with a header and no rows still names the columns rows are added to."""
    if mine is not None and len(mine.columns):
        for c in required:
            if c not in mine.columns:
                raise InputError("required column is missing: rows cannot be added to "
                                 "this table", file=campaign_file, column=c)
    for c in required:
        if c not in theirs.columns and (mine is None or not len(mine.columns)):
            raise InputError(MISSING_LINES.get((table, c), f"NEW's {table} has no column "
                                               f"'{c}', which its reader needs in every row"),
                             file=_file(rec, table))


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
    return [str(int(v)) for v in (counts["n00"] + counts["n11"]).tolist()]


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
