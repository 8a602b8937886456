"""The recordings ``dpdfit add`` adds, read as text tables with the place of every row.

:func:`read_new_recordings` reads NEW, a folder of CSV files in the campaign folder's
layout (any subset of the tables; ``campaign.json`` optional) or an import mapping of
ARTIQ/ndscan results files (read by :func:`~.mapping.read_mapping` with ``partial``
and imported by :func:`~.campaign_import.import_campaign`, exactly as ``dpdfit import``
reads it).  Every table comes back as text (the values as written, so that nothing is
re-rounded) with its rows' ``source_file`` and ``source_rid``; :class:`NewRecordings`
also keeps NEW's campaign constants and, per source file, its SHA-256, rid and start
time, and names any row in a message (:meth:`NewRecordings.where`).  Each file of a
folder NEW is checked before it is read (:mod:`.input_files`): a regular file inside
NEW (a link leading out of NEW is refused, never read), within the size bound.

:func:`read_text_table` reads a campaign table as the readers do (``#`` comment lines
skipped, spaces after a comma ignored, empty cells empty) but keeps every value as its
text; :func:`text_column` turns imported values into such text.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from dpdfit.errors import InputError

from .campaign_import import import_campaign
from .columns import CAMPAIGN_TABLES
from .input_files import check_inside, open_input, read_input_json
from .mapping import read_mapping
from .mapping_lines import KeyLines
from .outputs import file_sha256
from .tables import read_csv_strings

__all__ = ["NewRecordings", "read_new_recordings", "read_text_table", "text_column",
           "leading_comments", "SOURCE_COLUMNS"]

#: the provenance columns of every added row (the import's own)
SOURCE_COLUMNS = ("source_file", "source_rid")


@dataclass(frozen=True)
class NewRecordings:
    """NEW read: ``tables`` (name -> text DataFrame with ``source_file``/``source_rid``),
    ``constants`` (its campaign.json or the mapping's ``[campaign]``), ``sources`` (one
    dict per source file: file, sha256, rid, start_time), ``kind`` (``csv``/``mapping``)."""

    path: Path
    kind: str
    tables: dict
    constants: dict
    constants_file: str | None
    sources: tuple
    mapping_sha256: str | None = None
    mapping_text: str | None = field(default=None, repr=False)
    warnings: tuple = ()
    ignored: tuple = ()

    def where(self, table: str, row: int) -> dict:
        """``file`` (and ``row`` for a CSV) of NEW's 1-based ``row`` of ``table``, as
        :class:`~dpdfit.errors.InputError` takes them."""
        df = self.tables[table]
        if self.kind == "csv":
            return {"file": str(self.path / f"{table}.csv"), "row": int(df.index[row - 1]) + 1}
        r = df.iloc[row - 1]
        return {"file": f"{r['source_file']} (rid {r['source_rid']})"}

    def constants_line(self, key: str) -> str:
        """``key`` as named in NEW: ``campaign.json key 'k'`` or ``[campaign] k (line N)``."""
        if self.kind == "csv":
            return f"key '{key}'"
        table, _, name = key.rpartition(".")
        line = KeyLines(self.mapping_text or "").find(
            "campaign" + (f".{table}" if table else ""), name)
        return f"[campaign] {key}" + (f" (line {line})" if line else "")


def read_text_table(path: str | os.PathLike, within=None) -> pd.DataFrame:
    """A CSV table with every value as its text (module doc), read by
    :func:`~.tables.read_csv_strings` (inside the folder ``within`` when given; its header
    and rows checked); InputError naming the file when it cannot be read.  A file with a
    header and no rows is an empty table."""
    df = read_csv_strings(path, str(path), within=within)
    for c in df.columns:
        # spaces before a comma: stripped where a cell has them (each distinct value is
        # looked at once; stripping every cell of a million rows takes seconds)
        if any(isinstance(v, str) and v != v.strip() for v in df[c].unique()):
            df[c] = df[c].str.strip()
    return df


def leading_comments(path: str | os.PathLike, within=None) -> str:
    """The ``#`` lines at the top of a CSV file (kept on top when rows are appended); the
    file checked as :func:`~.input_files.open_input` checks it (inside ``within``)."""
    out = []
    with open_input(path, within=within, what="table") as fh:
        for raw in fh:
            line = raw.decode("utf-8", errors="replace")
            if not line.startswith("#"):
                break
            out.append(line if line.endswith("\n") else line + "\n")
    return "".join(out)


def text_column(values) -> list:
    """Imported values as text: integers without a decimal point, other floats by their
    shortest round-tripping repr, NaN and None empty."""
    arr = np.asarray(values)
    if arr.dtype.kind in "iub":
        return [str(int(v)) for v in arr]
    if arr.dtype.kind == "f":
        return ["" if not np.isfinite(v) else
                str(int(v)) if float(v).is_integer() and abs(v) < 1e15 else repr(float(v))
                for v in arr.tolist()]
    return ["" if v is None or (isinstance(v, float) and not np.isfinite(v)) else str(v)
            for v in arr.tolist()]


def read_new_recordings(new, *, complete_only=None, progress=None, skip_bad_files=None,
                        check=None) -> NewRecordings:
    """NEW read as text tables with provenance (module doc); the options go to the import
    when NEW is a mapping.  ``check(recordings)`` is called with NEW's constants (and no
    tables yet) before any table is read: a mapping of another campaign is refused before
    its results files are."""
    path = Path(new)
    check = check or (lambda rec: None)
    check_inside(path, path, "NEW")                 # a link loop
    if path.is_dir():
        return _csv_folder(path, check)
    if not path.exists():
        raise InputError("not found (give a folder of CSV files or an import mapping)",
                         file=str(path))
    if path.suffix.lower() != ".toml":
        raise InputError("is neither a folder of CSV files nor an import mapping (.toml)",
                         file=str(path))
    return _mapping(path, complete_only, progress, skip_bad_files, check)


def _csv_folder(path: Path, check) -> NewRecordings:
    for name in ("traces.csv", "traces"):
        if os.path.lexists(path / name):
            raise InputError(f"{name}: dpdfit add merges the tables, not raw traces; move "
                             "traces.csv and traces/ out of NEW (copy them to the new "
                             "campaign by hand if you want them there)", file=str(path))
    constants, constants_file = {}, None
    if os.path.lexists(path / "campaign.json"):
        constants_file = str(path / "campaign.json")
        constants = read_input_json(path / "campaign.json", within=path,
                                    what="campaign.json")
        if not isinstance(constants, dict):
            raise InputError("campaign.json must hold a JSON object", file=constants_file)
    check(NewRecordings(path=path, kind="csv", tables={}, constants=constants,
                        constants_file=constants_file, sources=()))
    tables, sources = {}, []
    for table in CAMPAIGN_TABLES:
        f = path / f"{table}.csv"
        if not os.path.lexists(f):
            continue
        df = read_text_table(f, within=path)
        if df.empty:
            continue
        for c in SOURCE_COLUMNS:         # NEW made by dpdfit import keeps its results files
            if c not in df.columns:      # one value for every row: a byte per row, not 8
                df[c] = pd.Categorical.from_codes(np.zeros(len(df), dtype=np.int8),
                                                  [f.name if c == "source_file" else ""])
        tables[table] = df
        sources.append({"file": f.name, "sha256": file_sha256(f), "rid": None,
                        "start_time": None})
    known = {f"{t}.csv" for t in CAMPAIGN_TABLES} | {"campaign.json"}
    ignored = tuple(sorted(p.name for p in path.iterdir() if p.name not in known))
    return NewRecordings(path=path, kind="csv", tables=tables, constants=constants,
                         constants_file=constants_file, sources=tuple(sources),
                         ignored=ignored)


def _mapping(path: Path, complete_only, progress, skip_bad_files, check) -> NewRecordings:
    m = read_mapping(path, partial=True)
    check(NewRecordings(path=path, kind="mapping", tables={}, constants=dict(m.campaign),
                        constants_file=str(path), sources=(), mapping_text=m.text))
    imported = import_campaign(m, complete_only=complete_only, progress=progress,
                               skip_bad_files=skip_bad_files)
    tables = {}
    for table, df in imported.tables.items():
        if len(df):
            tables[table] = pd.DataFrame({c: text_column(df[c].to_numpy()) for c in df.columns})
    info = imported.meta["imported"]
    sources = tuple({k: s[k] for k in ("file", "sha256", "rid", "start_time")}
                    for s in info["sources"])
    return NewRecordings(path=path, kind="mapping", tables=tables, constants=dict(m.campaign),
                         constants_file=str(path), sources=sources,
                         mapping_sha256=info["mapping_sha256"], mapping_text=m.text,
                         warnings=imported.notes())
