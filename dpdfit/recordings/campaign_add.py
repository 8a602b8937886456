"""New recordings merged into a copy of a campaign folder (``dpdfit add``).

:func:`add_recordings` reads a campaign folder (CAMPAIGN, through
:class:`~.campaign_folder.CampaignFolder`) and further recordings (NEW: a folder of
CSV files in the documented layout, any subset of the tables, ``campaign.json``
optional; or an import mapping of ARTIQ/ndscan results files, read exactly as
``dpdfit import`` reads it, :mod:`.add_sources`), checks that NEW belongs to the
campaign (:mod:`.add_checks`) and returns an :class:`AddedCampaign`, whose
:meth:`~AddedCampaign.write` writes the merged campaign into a new folder.
CAMPAIGN is never written.

Merge rules:

* every table: the campaign's rows unchanged and in order (their text as written), the
  new rows appended;
* ``populations``/``parity``: ``scan`` labels continue per setting ``(A, dpd)``, over
  both tables (a scan records both): a new scan ``k`` at a setting whose largest label
  in the campaign is ``m`` becomes ``m + `` the rank of ``k`` among NEW's labels there;
  repeated rows of one new scan stay one scan (the simulator's further scan is labelled
  ``1 + max`` too);
* ``spectra``: rows appended (a tone recorded again is a repeat); if the campaign's
  ``spectra.csv`` has a ``repeat`` column, it continues per tone ``(A, dpd, sideband,
  n)`` as the scans do;
* ``time_scans``, ``gate_rates``: rows appended (the readers pool repeated points and
  repeated calibrations);
* calibration runs: a ``run`` label new to the campaign is added as it is; a label the
  campaign has, with the same rows, is skipped as already there (the report says so);
  with other rows it is refused;
* columns: a column of the campaign that NEW lacks is refused when a reader needs it
  in every row, except ``n_even`` (``n00 + n11``), ``valid`` (1, as without the column),
  ``snr_db`` (empty: estimated) and ``repeat``; an optional column NEW has and the
  campaign lacks is dropped (said in the report); other extra columns are kept (empty
  where a row has none);
* every added row carries ``source_file`` and ``source_rid``: the import's for a
  mapping; for CSV files NEW's own when it has them, else the CSV file (relative to
  NEW) and an empty rid; the campaign's rows keep theirs (empty when the columns are new);
* ``campaign.json`` is copied with one new key, ``added``: a list with one entry per
  ``dpdfit add`` (:func:`provenance`); nothing else of it changes;
* the other files of the campaign layout are copied unchanged: the tables without rows
  added, ``traces.csv`` and the trace files it names, ``budget.toml``, ``README.md``;
  ``truth.json`` (a simulator's truth that no longer describes the folder) is dropped,
  and said so; any other file or folder of CAMPAIGN is left out, each named in the
  report, and nothing of it is read (:mod:`.add_files`).

Every file of CAMPAIGN and NEW that is read or copied is a regular file inside its
folder (a link may point elsewhere in the folder, never out of it), at most
:func:`~.input_files.max_input_bytes` (``campaign.json``:
:data:`~dpdfit.core.defaults.MAX_JSON_BYTES`), checked before it is read; a copy is
written fresh, never as a link.  A link out of either folder, a FIFO, a device or a
folder in a file's place is refused in one line naming the file.

NEW's raw traces (``traces.csv``, ``traces/``) are refused with a line saying so: copy
them by hand.  The merged folder is read back with the campaign folder's own readers
before it appears (a refusal names CAMPAIGN's or NEW's file and row) and is written
atomically (:func:`~.outputs.staged_folder`).
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from dpdfit.core.display import Displayable
from dpdfit.core.version import __version__
from dpdfit.errors import InputError, RefusedFileError

from .add_checks import check_output, check_same_campaign, check_settings
from .add_files import DROPPED_FILES, CampaignCopy, plan_copy
from .add_merge import merge_table, renumber_scans
from .add_sources import NewRecordings, leading_comments, read_new_recordings, read_text_table
from .campaign_folder import CampaignFolder
from .imported_check import READERS
from .outputs import refuse_formula_cells, staged_folder, write_csv_table

__all__ = ["AddedCampaign", "add_recordings", "provenance", "DROPPED_FILES"]


@dataclass(frozen=True, repr=False)
class AddedCampaign(Displayable):
    """A campaign with further recordings merged in, ready to be written (module doc).

    ``rows_added``: table -> rows added; ``tables``: the merged tables (text) that
    changed; ``meta``: the new ``campaign.json``; ``skipped``, ``dropped``, ``left_out``
    (CAMPAIGN's files not of the layout), ``notes``: lines of the report.

    Each merged table is kept as its two parts, the campaign's rows and NEW's, and
    written part after part: a million rows added are never copied into one table."""

    campaign: Path
    new: Path
    kind: str
    rows_added: dict
    skipped: tuple = ()
    dropped: tuple = ()
    notes: tuple = ()
    meta: dict = field(default_factory=dict)
    left_out: tuple = ()
    _parts: dict = field(default_factory=dict)
    _origin: dict = field(default_factory=dict)
    _recordings: NewRecordings | None = None
    _copy: CampaignCopy = field(default_factory=CampaignCopy)
    _comments: dict = field(default_factory=dict)
    _columns: dict = field(default_factory=dict)
    _display_title = "Recordings added"

    @property
    def tables(self) -> dict:
        """The merged tables (text) that changed: table -> DataFrame, the campaign's rows
        then NEW's (made on each access)."""
        return {t: df if mine is None else pd.concat([mine, df], ignore_index=True)
                for t, (mine, df) in self._parts.items()}

    def _rows(self, table: str) -> int:
        """Rows of the merged ``table``."""
        mine, df = self._parts[table]
        return len(df) + (0 if mine is None else len(mine))

    def _display_rows(self) -> list[tuple]:
        return [(f"{t} rows added", n, None, "") for t, n in self.rows_added.items()]

    def _display_diagnostics(self) -> dict:
        return {"warnings": list(self.skipped + self.dropped + self.left_out + self.notes)}

    def report(self) -> str:
        """What is added: rows per table (and the total they make), then the runs skipped,
        the files dropped, the files left out and the notes, one line each."""
        n_src = len(self.meta["added"][-1]["sources"])
        lines = [f"added to {self.campaign} from {self.new} ({self.kind}, {n_src} source "
                 f"file{'s' if n_src != 1 else ''}):"]
        for t, n in self.rows_added.items():
            lines.append(f"  {t + '.csv':26s} {f'+{n}':>7s} rows (now {self._rows(t)})")
        lines += [f"  skipped: {s}" for s in self.skipped]
        lines += [f"  dropped: {d}" for d in self.dropped]
        lines += [f"  left out: {x}" for x in self.left_out]
        lines += [f"  note: {x}" for x in self.notes]
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """``campaign``, ``new``, ``kind``, ``rows_added``, ``skipped``, ``dropped``,
        ``left_out``, ``notes`` and ``added`` (the entry of ``campaign.json``'s
        ``added``)."""
        return {"campaign": str(self.campaign), "new": str(self.new), "kind": self.kind,
                "rows_added": dict(self.rows_added), "skipped": list(self.skipped),
                "dropped": list(self.dropped), "left_out": list(self.left_out),
                "notes": list(self.notes), "added": self.meta["added"][-1]}

    def write(self, out) -> Path:
        """Write the merged campaign into the new folder ``out`` (atomically; refused if it
        exists or lies inside CAMPAIGN), after reading it back with the campaign folder's
        readers (a refusal names the file and row the value came from).  Of CAMPAIGN's
        other files, those of the layout are copied (module doc)."""
        rec = self._recordings
        check_output(out, self.campaign, self.new, rec is not None and rec.kind == "csv")
        with staged_folder(out) as tmp:
            self._copy.copy(self.campaign, tmp, skip={f"{t}.csv" for t in self._parts})
            for t, (mine, df) in self._parts.items():
                head = self._comments.get(t, "")
                name = Path(out) / f"{t}.csv"
                if mine is not None:
                    write_csv_table(tmp / f"{t}.csv", mine, name=name, head=head,
                                    lineterminator="\n")
                write_csv_table(tmp / f"{t}.csv", df, name=name, head="" if mine is not None
                                else head, header=mine is None,
                                mode="w" if mine is None else "a", lineterminator="\n")
            (tmp / "campaign.json").write_text(json.dumps(self.meta, indent=2) + "\n",
                                               encoding="utf-8")
            self._read_back(tmp)
        return Path(out)

    def _read_back(self, tmp: Path) -> None:
        camp = CampaignFolder(tmp)
        # the recording times are checked against the amplitude runs: a copied table is
        # read first, so that a refusal of its rows names the campaign's file and row
        copied = [t for t in ("calibration_amplitude",) if t not in self._parts
                  and camp.raw_meta.keys() & {"spectra_recorded", "gates_recorded"}
                  and camp.has(f"{t}.csv")]
        for t in [*self._parts, *copied]:
            try:
                getattr(camp, READERS[t])
            except InputError as exc:
                raise self._traced(exc, t) from None
        try:
            camp.recording_times
        except InputError as exc:
            raise InputError(f"with the recordings added: {_message(exc)}",
                             file=str(self.campaign / "campaign.json")) from None

    def _check_cells(self) -> None:
        """Refuse a text cell of a merged table that a spreadsheet would run as a formula
        (:func:`~.outputs.refuse_formula_cells`), naming CAMPAIGN's or NEW's row."""
        for t, (mine, df) in self._parts.items():
            n0 = 0 if mine is None else len(mine)
            try:
                if mine is not None:
                    refuse_formula_cells(mine, f"{t}.csv")
                try:
                    refuse_formula_cells(df, f"{t}.csv")
                except InputError as exc:   # rows counted in the merged table
                    raise InputError(_message(exc), file=exc.file, column=exc.column,
                                     row=None if exc.row is None else exc.row + n0) from None
            except InputError as exc:
                if exc.row is None:         # a column name: the campaign's, or NEW's
                    rec = self._recordings
                    file = (self.campaign / f"{t}.csv" if exc.column in
                            self._columns.get(t, ()) else rec.path / f"{t}.csv"
                            if rec.kind == "csv" else rec.path)
                    raise InputError(_message(exc), file=str(file), column=exc.column) \
                        from None
                raise self._traced(exc, t) from None

    def _traced(self, exc: InputError, table: str) -> InputError:
        """The readers' refusal of the merged ``table``, naming CAMPAIGN's or NEW's row."""
        msg, origin = _message(exc), self._origin.get(table)
        if table not in self._parts:        # copied unchanged: the campaign's own rows
            return InputError(msg, file=str(self.campaign / f"{table}.csv"),
                              column=exc.column, row=exc.row)
        n0 = self._rows(table) - (0 if origin is None else len(origin))
        if exc.row is None:
            return InputError(f"{table}.csv with the recordings added: {msg}",
                              file=str(self.campaign / f"{table}.csv"))
        if exc.row <= n0:
            return InputError(f"with the recordings added: {msg}",
                              file=str(self.campaign / f"{table}.csv"), column=exc.column,
                              row=exc.row)
        where = self._recordings.where(table, int(origin[exc.row - n0 - 1]) + 1)
        return InputError(f"added as row {exc.row} of {table}.csv: {msg}", column=exc.column,
                          **where)


def _message(exc: InputError) -> str:
    """The message without its file (a staged one) and its line there."""
    text = str(exc)
    if exc.file is not None and text.startswith(str(exc.file)):
        text = text[len(str(exc.file)):].lstrip(", ")
        text = re.sub(r"^(column '[^']*'(, )?)?(row \d+)?: ", "", text)
    return re.sub(r" \(line \d+\)$", "", text)


def add_recordings(campaign, new, *, added_at=None, complete_only=None, progress=None,
                   skip_bad_files=None) -> AddedCampaign:
    """CAMPAIGN with NEW's recordings merged in (module doc), not yet written.

    Parameters
    ----------
    campaign : path-like
        The campaign folder (never written).
    new : path-like
        A folder of CSV files in the campaign layout, or an import mapping (``.toml``).
    added_at : datetime or str, optional
        When the recordings are added (``campaign.json``'s ``added``; default now, UTC).
    complete_only, progress, skip_bad_files : bool, optional
        Passed to :func:`~.campaign_import.import_campaign` when NEW is a mapping.

    Raises
    ------
    InputError
        NEW from another campaign, a setting the campaign cannot model, a run label the
        campaign has with other data, NEW with nothing to add (:mod:`.add_checks`).
    """
    camp = CampaignFolder(campaign)
    if not isinstance(camp.raw_meta.get("added", []), list):
        raise InputError("key 'added' must be a list (the recordings added before)",
                         file=str(camp.file("campaign.json")))
    copy = plan_copy(camp.path, {"campaign.json"}, _trace_files(camp))
    rec = read_new_recordings(new, complete_only=complete_only, progress=progress,
                              skip_bad_files=skip_bad_files, check=lambda r: check_same_campaign(
                                  camp.raw_meta, str(camp.file("campaign.json")), r))
    check_settings(rec)
    comments = {}
    mine = {t: _campaign_table(camp, t, comments) for t in
            sorted({*rec.tables, "populations", "parity"})}
    columns = {t: tuple(df.columns) for t, df in mine.items() if df is not None}
    parts, origin, skipped, notes, kept = {}, {}, [], [], {}
    for t, df in rec.tables.items():
        kept[t], mine[t], skip, note = merge_table(t, mine[t], df, rec,
                                                   str(camp.file(f"{t}.csv")))
        skipped += skip
        notes += note
    notes += renumber_scans(mine, kept)
    for t, df in kept.items():
        if df.empty:
            continue
        origin[t] = df.index.to_numpy()
        parts[t] = (mine[t], df)
    if not parts:
        raise InputError("nothing to add: " + ("every calibration run is in the campaign "
                         "already" if skipped else "NEW holds no rows of any campaign table"),
                         file=str(rec.path))
    rows = {t: len(origin[t]) for t in parts}
    meta = dict(camp.raw_meta)
    meta["added"] = list(camp.raw_meta.get("added", [])) + [
        provenance(rec, {t: len(df) + (0 if m is None else len(m))
                         for t, (m, df) in parts.items()}, origin, skipped, added_at)]
    dropped = tuple(f"{n} ({why})" for n, why in DROPPED_FILES.items()
                    if os.path.lexists(camp.file(n)))
    notes += [f"not added: {n} (NEW's files other than the tables)" for n in rec.ignored]
    notes += [f"import: {w}" for w in rec.warnings]
    added = AddedCampaign(campaign=camp.path, new=rec.path, kind=rec.kind, rows_added=rows,
                          skipped=tuple(skipped), dropped=dropped, notes=tuple(notes),
                          meta=meta, left_out=copy.left_out, _parts=parts, _origin=origin,
                          _recordings=rec, _copy=copy, _comments=comments, _columns=columns)
    added._check_cells()
    return added


def _campaign_table(camp: CampaignFolder, table: str, comments: dict):
    """The campaign's ``table`` as text (checked first: a regular file inside CAMPAIGN,
    within the size bound), None without the file; its leading ``#`` lines go into
    ``comments``."""
    f = camp.file(f"{table}.csv")
    if not os.path.lexists(f):
        return None
    df = read_text_table(f, within=camp.path)
    comments[table] = leading_comments(f, within=camp.path)
    return df


def _trace_files(camp: CampaignFolder):
    """The ``file`` column of CAMPAIGN's ``traces.csv`` (empty without the file), or why
    it cannot be read (a line of the report: the traces are then left out)."""
    f = camp.file("traces.csv")
    if not os.path.lexists(f):
        return []
    try:
        df = read_text_table(f, within=camp.path)
    except RefusedFileError:        # not a table, or not inside CAMPAIGN: refused
        raise
    except InputError as exc:
        return _message(exc)
    if len(df) and "file" not in df.columns:
        return "it has no column 'file'"
    return df["file"].tolist() if len(df) else []


def provenance(rec: NewRecordings, totals: dict, origin: dict, skipped, added_at=None) -> dict:
    """The ``added`` entry of ``campaign.json``: ``added_at`` (UTC, ISO 8601), ``from`` (NEW
    as given), ``kind``, ``mapping_sha256`` (a mapping), ``dpdfit`` (version),
    ``rows`` (table -> ``[first, last]`` data rows added), ``skipped`` and ``sources``:
    per source file its ``file``, ``sha256``, ``rid``, ``start_time`` and ``rows`` (table
    -> list of ``[first, last]`` data rows of the new folder it gave).  ``totals``: table
    -> rows of the merged table; ``origin``: table -> the index in ``rec.tables`` of
    NEW's rows added."""
    when = _utc(added_at)
    per_file = {s["file"]: {**s, "rows": {}} for s in rec.sources}
    rows = {}
    for t, total in totals.items():
        n0 = total - len(origin[t])
        rows[t] = [n0 + 1, total]
        files = ([f"{t}.csv"] * len(origin[t]) if rec.kind == "csv"
                 else rec.tables[t].loc[origin[t], "source_file"].tolist())
        for f, a, b in _runs(files):
            per_file.setdefault(f, {"file": f, "sha256": None, "rid": None,
                                    "start_time": None, "rows": {}})
            per_file[f]["rows"].setdefault(t, []).append([n0 + a + 1, n0 + b + 1])
    entry = {"added_at": when, "from": str(rec.path), "kind": rec.kind}
    if rec.kind == "mapping":
        entry["mapping_sha256"] = rec.mapping_sha256
    entry.update({"dpdfit": __version__, "rows": rows, "skipped": list(skipped),
                  "sources": list(per_file.values())})
    return entry


def _runs(values: list):
    """(value, first, last) of each run of equal consecutive values (0-based positions)."""
    out, start = [], 0
    for i in range(1, len(values) + 1):
        if i == len(values) or values[i] != values[start]:
            out.append((values[start], start, i - 1))
            start = i
    return out


def _utc(when) -> str:
    if when is None:
        when = _dt.datetime.now(_dt.timezone.utc)
    t = pd.Timestamp(when)
    t = t.tz_localize("UTC") if t.tzinfo is None else t.tz_convert("UTC")
    return t.isoformat()

