"""Import a lab's ARTIQ results files into a campaign folder, following a mapping.

:func:`import_campaign` reads every results file a :class:`~.mapping.Mapping`
names (each once), builds the campaign tables row by row (one row per ndscan
point, or per value of a plain per-point dataset, or one per file), converts
units, checks values and counts, and returns an :class:`ImportedCampaign`;
:meth:`ImportedCampaign.write` writes the documented campaign folder
atomically and checks it with the campaign folder's own readers before it
appears.

Every row keeps where it came from: ``source_file`` (relative to the mapping)
and ``source_rid``, extra columns the readers ignore.  ``campaign.json`` lists
every source file with its SHA-256, rid and start time.  A point measured again
stays a separate row; the ``scan`` column of populations and parity, when the
mapping does not give it, numbers the repeats of each setting (1, 2, ...) in
acquisition order (files by start time, then rid).  The recording times default
to the earliest start time of the spectra's and of the gates' files.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from dpdfit.core.defaults import MAX_FILES_PER_SOURCE
from dpdfit.core.progress import progress_bar
from dpdfit.core.version import __version__
from dpdfit.errors import InputError

from .artiq import ResultsFile, read_results_file
from .imported_check import check_imported
from .file_globs import source_files
from .mapped_columns import column_values, fail
from .mapping import TABLE_COLUMNS, Mapping, SourceSpec, read_mapping
from .name_patterns import matching_keys
from .units import COLUMN_KINDS
from .outputs import staged_folder, write_csv_table

__all__ = ["ImportedCampaign", "import_campaign", "GATE_TABLES", "COUNT_COLUMNS"]

#: tables recorded with the gates (their earliest run is campaign.json's gates_recorded)
GATE_TABLES = ("populations", "parity", "time_scans", "gate_rates")
#: count columns, each at most ``shots``
COUNT_COLUMNS = ("n_even", "n00", "n01_10", "n11")
_SCAN_KEYS = {"populations": ["A", "dpd"], "parity": ["A", "dpd", "phase_rad"]}
#: sorts a run without a start time last
_NEVER = pd.Timestamp.max.tz_localize("UTC")


@dataclass(frozen=True)
class ImportedCampaign:
    """The campaign tables built from results files, ready to be written as a folder."""

    tables: dict
    meta: dict
    warnings: tuple = ()
    skipped: tuple = ()
    mapping: Mapping | None = field(default=None, repr=False)

    def report(self, notes: bool = True) -> str:
        """What was imported, as text: rows and source files per table, then (with
        ``notes``) the warnings and the incomplete scans skipped, one line each."""
        lines = [f"{t:22s} {len(df):6d} rows from {df['source_file'].nunique()} files"
                 for t, df in self.tables.items()]
        return "\n".join(lines + (list(self.notes()) if notes else []))

    def notes(self) -> tuple:
        """The warnings and the incomplete scans skipped, one line each."""
        return tuple([f"warning: {w}" for w in self.warnings]
                     + [f"skipped (incomplete): {s}" for s in self.skipped])

    def write(self, folder) -> Path:
        """Write the campaign folder (atomically: it appears complete or not at all).

        Refuses a folder that exists and is not empty (never overwrites).  The
        written tables and ``campaign.json`` are read back with the campaign folder's own
        readers first (:func:`~.imported_check.check_imported`); a value they refuse is
        reported with the results file it came from.
        """
        folder = Path(folder)
        if folder.exists() and (not folder.is_dir() or any(folder.iterdir())):
            raise InputError("exists and is not empty: dpdfit import writes a new campaign "
                             "folder and never overwrites one", file=str(folder))
        with staged_folder(folder) as tmp:
            for name, df in self.tables.items():
                write_csv_table(tmp / f"{name}.csv", df, name=folder / f"{name}.csv")
            (tmp / "campaign.json").write_text(json.dumps(self.meta, indent=2) + "\n",
                                               encoding="utf-8")
            self._check(tmp)
        return folder

    def _check(self, tmp: Path) -> None:
        check_imported(tmp, self.tables, self.meta, self.mapping)


def import_campaign(mapping, *, complete_only: bool | None = None,
                    progress: bool | None = None,
                    skip_bad_files: bool | None = None) -> ImportedCampaign:
    """Build the campaign tables a mapping describes (module doc).

    Each results file is read once, for every source that names it, and only its
    rows and provenance are kept, so a month of results files streams through.
    Nothing is logged: the warnings are the result's ``warnings`` (the command
    line prints them after the campaign is written, so that an error comes first).

    Parameters
    ----------
    mapping : Mapping or path-like
        The mapping (:func:`~dpdfit.recordings.mapping.read_mapping`) or its file.
    complete_only : bool, optional
        Skip ndscan scans that did not complete (default: the mapping's
        ``[import] complete_only``, else import them with a warning).
    progress : bool, optional
        A progress bar over the files (default: when stderr is a terminal).
    skip_bad_files : bool, optional
        Skip a results file that cannot be read, or that a source cannot take rows
        from, with a warning naming it and why (default: the mapping's ``[import]
        skip_bad_files``, else such a file stops the import).  A source that takes no
        file at all still stops it, with the first file's error.
    """
    m = mapping if isinstance(mapping, Mapping) else read_mapping(mapping)
    complete_only = m.complete_only if complete_only is None else complete_only
    skip = m.skip_bad_files if skip_bad_files is None else skip_bad_files
    plan = {}                                    # results file -> the sources naming it
    named = {}                                   # (device, inode) -> the path read
    for src in m.sources:
        for path in _expand(m, src, named):
            plan.setdefault(path, []).append(src)
    # per file only its provenance, and per source its rows as plain arrays: a pandas
    # frame per file costs ~8 kB of overhead, which at 10,000 files was 6x the tables
    provenance, chunks = {}, {t: [] for t in TABLE_COLUMNS}
    warnings, skipped, refused = [], [], {}
    for path, sources in progress_bar(plan.items(), total=len(plan), desc="import",
                                      unit="file", progress=progress):
        rel = _relative(path, m.folder)
        try:
            rf = read_results_file(path, name=rel, max_dataset_bytes=m.max_dataset_bytes)
        except InputError as exc:
            if not skip:
                raise
            for src in sources:
                refused.setdefault(src.key, exc)
            warnings.append(f"{exc}; skipped (--skip-bad-files)")
            continue
        provenance[path] = _provenance(rf.run, rel)
        for src in sources:
            try:
                with rf:                 # the file open while this source's rows are read
                    df, scan, notes = _rows(src, rf, rel)
            except InputError as exc:
                if not skip:
                    raise
                refused.setdefault(src.key, exc)
                warnings.append(f"{exc}; skipped for {src.key} (--skip-bad-files)")
                continue
            warnings += notes
            if scan is not None and scan.completed is False:
                what = f"{rel}: ndscan root '{scan.root}' did not complete ({len(df)} points)"
                if complete_only:
                    skipped.append(what)
                    continue
                warnings.append(what + "; imported (--complete-only skips it)")
            t0 = _NEVER if rf.run.start_time is None else rf.run.start_time
            chunks[src.table].append(((t0, rf.run.rid or 0, src.index), len(df),
                                      {c: df[c].to_numpy() for c in df.columns}))
            if len(df):
                provenance[path]["tables"].append(src.table)
    for src in m.sources:                 # a mapping mistake must not skip every file
        if src.key in refused and not any(p[0][2] == src.index for p in chunks[src.table]):
            raise refused[src.key]
    tables = {t: _table(t, parts) for t, parts in chunks.items() if parts}
    meta = _meta(m, provenance, chunks, warnings)
    return ImportedCampaign(tables=tables, meta=meta, warnings=tuple(dict.fromkeys(warnings)),
                            skipped=tuple(skipped), mapping=m)


def _table(table: str, parts: list) -> pd.DataFrame:
    """One campaign table from its parts (sort key, rows, columns), in the order of
    their start times; a column a part lacks is NaN there, as pandas.concat does."""
    parts = sorted(parts, key=lambda p: p[0])
    names = list(dict.fromkeys(c for p in parts for c in p[2]))
    df = pd.DataFrame({c: np.concatenate([p[2][c] if c in p[2] else np.full(p[1], np.nan)
                                          for p in parts]) for c in names})
    if table in _SCAN_KEYS and "scan" not in df.columns:
        df.insert(2, "scan", df.groupby(_SCAN_KEYS[table], sort=False).cumcount() + 1)
    return _ordered(df, table)


def _provenance(run, rel: str) -> dict:
    """``campaign.json``'s entry for one results file (its tables are added as read)."""
    return {"file": rel, "sha256": run.sha256, "rid": run.rid,
            "start_time": None if run.start_time is None else run.start_time.isoformat(),
            "class_name": run.expid.get("class_name"), "artiq_version": run.artiq_version,
            "tables": []}


def _expand(m: Mapping, src: SourceSpec, named: dict) -> list[str]:
    where = f"mapping key '{src.key}.files' (line {src.files_line})"
    return source_files(src.files, m.folder, named, MAX_FILES_PER_SOURCE, where, str(m.path))


def _relative(path: str, folder: Path) -> str:
    try:
        return Path(os.path.relpath(path, folder)).as_posix()
    except ValueError:                                 # another drive (Windows)
        return Path(path).as_posix()


def _rows(src: SourceSpec, rf: ResultsFile, rel: str):
    """The rows one results file contributes to one source's table."""
    uses_scan = any(c.source in ("axis", "channel")
                    or (c.expression is not None and any(
                        f in ("axis", "channel") for f, _ in c.expression.references))
                    for c in src.columns.values())
    scan = rf.scan(src.root) if uses_scan or src.subscan else None
    if src.subscan:                      # one row per inner point (ndscan_scan)
        scan = scan.subscan(src.subscan, rf.run.file)
    keys = _pattern_keys(src, rf, scan) if src.placeholders else [{}]
    parts, notes = [], []
    for key in keys:
        columns = {c: spec.filled(key) for c, spec in src.columns.items()}
        if scan is not None:
            n, note = _scan_points(scan, rf)
        else:
            n = _dataset_rows(columns, rf)
            note = _fewer_than_planned(rf, n)
        notes += [note] if note else []
        df = pd.DataFrame({c: column_values(spec, rf, scan, n) for c, spec in columns.items()})
        for k, value in key.items():
            df[k] = value
        df["_point"] = np.arange(n)
        df, note = _unmeasured_dropped(df, columns, rel)
        notes += [note] if note else []
        _check_counts(df, src, rf, scan)
        parts.append(df)
    # one row per point and match, points in acquisition order
    df = pd.concat(parts, ignore_index=True).sort_values("_point", kind="stable")
    df = df.drop(columns="_point").reset_index(drop=True)
    df["source_file"] = rel
    df["source_rid"] = rf.run.rid if rf.run.rid is not None else -1
    return df, scan, notes


def _unmeasured_dropped(df: pd.DataFrame, columns: dict, rel: str):
    """Drop the points where a ``count = "all"`` column found no outcome at all: an
    array pre-filled with NaN (or empty) that the run never reached."""
    counted = [c for c, spec in columns.items() if spec.count == "all"]
    if not counted or df.empty:
        return df, None
    none = (df[counted] == 0).any(axis=1).to_numpy()
    if not none.any():
        return df, None
    note = (f"{rel}: {int(none.sum())} of {len(df)} points of '{columns[counted[0]].name}' "
            "hold no outcome (NaN or empty: never measured): dropped")
    return df.loc[~none].reset_index(drop=True), note


def _fewer_than_planned(rf: ResultsFile, n: int) -> str | None:
    """A warning when a run without ndscan (no ``completed`` flag) recorded fewer points
    than its one scanned Scannable argument planned: an interrupted scan looks short."""
    planned = {k: v.get("npoints", len(v.get("sequence") or ()))
               for k, v in rf.run.arguments.items()
               if isinstance(v, dict) and v.get("ty") not in (None, "NoScan")}
    if len(planned) != 1 or n <= 1:
        return None
    (name, total), = planned.items()
    if isinstance(total, int) and n < total:
        return (f"{rf.run.file}: {n} points recorded of the {total} its scan argument "
                f"'{name}' planned: interrupted? (imported as recorded)")
    return None


def _dataset_rows(columns: dict, rf: ResultsFile) -> int:
    names = [c.name for c in columns.values() if c.source == "dataset"]
    names += [n for c in columns.values() if c.expression is not None
              for f, n in c.expression.references if f == "dataset"]
    lengths = {len(np.atleast_1d(rf.datasets[n][0])) for n in names
               if n in rf.datasets and np.ndim(rf.datasets[n][0]) > 0}
    if len(lengths) > 1:
        raise InputError(f"per-point datasets of different lengths {sorted(lengths)}",
                         file=rf.run.file)
    return lengths.pop() if lengths else 1


def _pattern_keys(src: SourceSpec, rf: ResultsFile, scan) -> list[dict]:
    """Every match of the source's name pattern among the file's names (name_patterns)."""
    spec = next(c for c in src.columns.values() if c.placeholders)
    source, pattern = spec.source, spec.name
    if spec.expression is not None:
        source, pattern = next((f, n) for f, n in spec.expression.references if "{" in n)
    names = {"axis": lambda: [a.name for a in scan.axes],
             "channel": lambda: list(scan.channels),
             "dataset": lambda: list(rf.datasets)}[source]()
    numeric = {k for k in src.placeholders if COLUMN_KINDS[k][0] == "number"}
    keys = matching_keys(pattern, names, numeric)
    if not keys:
        fail(spec, rf, f"no {source} matches the pattern '{pattern}' (the file has: "
              f"{', '.join(names[:12]) or 'none'}{', ...' if len(names) > 12 else ''})", scan)
    return keys


def _scan_points(scan, rf: ResultsFile):
    """(points, a warning or None): an interrupted scan may end inside a point, whose
    partial last point is dropped, as ndscan's tools do."""
    lengths = scan.point_counts()             # a channel not used is not read for it
    n = min(lengths.values()) if lengths else 0
    if len(set(lengths.values())) > 1:
        longest = max(lengths, key=lengths.get)
        shortest = min(lengths, key=lengths.get)
        if scan.completed is not False:
            raise InputError(f"root '{scan.root}': dataset '{longest}' has {lengths[longest]} "
                             f"points but '{shortest}' has {lengths[shortest]}",
                             file=rf.run.file)
        return n, (f"{rf.run.file}: root '{scan.root}' interrupted inside a point: its last "
                   "partial point dropped")
    return n, None


def _check_counts(df: pd.DataFrame, src: SourceSpec, rf: ResultsFile, scan) -> None:
    if "shots" not in df.columns:
        return
    for c in COUNT_COLUMNS:
        if c in df.columns:
            bad = (df[c] > df["shots"]).to_numpy()
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                spec = src.columns[c]
                ds = None
                if scan is not None and spec.source in ("axis", "channel"):
                    ds = (scan.axis(spec.name) if spec.source == "axis"
                          else scan.channel(spec.name)).dataset
                point = int(df["_point"].iloc[i]) + 1 if "_point" in df else i + 1
                fail(spec, rf, f"point {point}: {c} = {df[c].iloc[i]} exceeds shots = "
                      f"{df['shots'].iloc[i]}", scan, ds)


def _ordered(df: pd.DataFrame, table: str) -> pd.DataFrame:
    required, optional = TABLE_COLUMNS[table]
    doc = [c for c in ("run", "timestamp") if c in df.columns] + \
        [c for c in (*required, *optional) if c in df.columns and c not in ("run", "timestamp")]
    if table in _SCAN_KEYS:                     # the bundled layout: A, dpd, scan, ...
        doc = ["A", "dpd", "scan"] + [c for c in doc if c not in ("A", "dpd", "scan")]
    return df[doc + ["source_file", "source_rid"]]


def _meta(m: Mapping, provenance: dict, chunks: dict, warnings: list) -> dict:
    meta = json.loads(json.dumps(m.campaign, default=str))   # TOML dates become text

    def earliest(tables):
        ts = [p[0][0] for t in tables for p in chunks[t] if p[0][0] != _NEVER]
        return min(ts).isoformat() if ts else None

    if "spectra_recorded" not in meta and earliest(["spectra"]):
        meta["spectra_recorded"] = earliest(["spectra"])
    if "gates_recorded" not in meta and earliest(GATE_TABLES):
        meta["gates_recorded"] = earliest(GATE_TABLES)
    sources = [dict(p, tables=[t for t in TABLE_COLUMNS if t in p["tables"]])
               for p in provenance.values()]
    meta["imported"] = {"dpdfit": __version__, "mapping": _relative(str(m.path), m.folder),
                        "mapping_sha256": hashlib.sha256(m.text.encode()).hexdigest(),
                        "warnings": list(warnings), "sources": sources}
    return meta
