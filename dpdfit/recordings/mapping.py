"""The import mapping: which results files hold each campaign table, and where each column is.

A mapping is a TOML file (read with :mod:`tomllib`); the annotated examples are
``examples/import/*.toml`` and the documentation's guide page "Importing lab recordings" (docs/guide/import.md).
Its top-level keys:

* ``[import]`` -- options of the import: ``complete_only`` (skip ndscan scans
  that did not complete; the command's ``--complete-only``),
  ``skip_bad_files`` (skip, with a warning each, the results files a source
  cannot read; ``--skip-bad-files``) and ``max_dataset_bytes`` (the largest
  HDF5 dataset read, default :data:`~dpdfit.core.defaults.MAX_DATASET_BYTES`).
* ``[campaign]`` -- keys of ``campaign.json`` (:data:`CAMPAIGN_KEYS`), copied.
* ``[[calibration_amplitude]]``, ``[[calibration_phase]]``, ``[[spectra]]``,
  ``[[populations]]``, ``[[parity]]``, ``[[time_scans]]``, ``[[gate_rates]]``
  -- one entry per *source* of that campaign table: ``files`` (a glob or a list
  of globs, relative to the mapping file; ``**`` allowed), optional ``root``
  (the ndscan root prefix, a glob; default the file's only root) and
  ``columns``, one key per campaign column; optional ``subscan`` (an ndscan
  subscan of that root: one row per inner point, :mod:`.ndscan_subscans`).

A column is a constant (a bare value, or ``{ value = ... }``) or exactly one of
``axis`` (ndscan axis: short name or fqn), ``channel`` (ndscan result channel),
``argument`` (the run's expid argument), ``parameter`` (an ndscan parameter
overridden for the whole run), ``dataset`` (a plain archived dataset: one value
per point, or one for all), ``run`` (``rid``, ``start_time`` or ``file``),
``expr`` (a computed value, :mod:`.expressions`), with the modifiers ``unit`` (the unit the stored values are in; else what the file
says; a constant is in the column's own), ``full_scale_dbm`` (``A`` given in dBm),
``format`` (:meth:`str.format` of the value), ``labels`` (codes to names) and
``count`` (per-shot outcomes: the number of shots whose outcome is in the
value or list given; ``"all"`` every recorded shot).

A source name with placeholders (``channel = "P_{sideband}_{n}"``) is a
pattern: every matching name gives rows, the placeholders' columns read from
the name (:mod:`.name_patterns`).

Any key dpdfit does not know is an error naming the key and its line.
"""

from __future__ import annotations

import difflib
import re
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path

from dpdfit.errors import InputError

from .columns import CAMPAIGN_TABLES
from .expressions import Expression, ExpressionError, parse_expression
from .name_patterns import fill, placeholders
from .units import COLUMN_KINDS

__all__ = ["ColumnSpec", "SourceSpec", "Mapping", "read_mapping", "TABLE_COLUMNS",
           "CAMPAIGN_KEYS", "SOURCES", "MODIFIERS"]


def _mapped(required: tuple, optional: tuple) -> tuple:
    """A table's columns in a mapping: the readers' own, with ``scan`` optional (the
    import numbers a setting's scans when no column gives them)."""
    if "scan" not in required:
        return required, optional
    return tuple(c for c in required if c != "scan"), ("scan", *optional)


#: campaign table -> (required columns, optional columns) of a mapping: derived from the
#: readers' (:data:`~dpdfit.recordings.columns.CAMPAIGN_TABLES`)
TABLE_COLUMNS = {table: _mapped(*cols) for table, cols in CAMPAIGN_TABLES.items()}
#: keys of campaign.json that a mapping may set (the campaign folder's; informational ones too)
CAMPAIGN_KEYS = ("name", "nu_hz", "xi0_spectra_hz", "nbar_assumed", "eta_ref", "eta_ld",
                 "order", "predistortion_table", "phase_run_for_model", "error_model",
                 "spectra_recorded", "gates_recorded", "f_det_hz", "fs_traces_hz",
                 "gate_waveform", "nominal_shots", "parity_phases", "units", "generator",
                 "synthetic", "notes")
#: where a column's values come from (exactly one per column)
SOURCES = ("value", "axis", "channel", "argument", "parameter", "dataset", "run", "expr")
#: what may accompany the source
MODIFIERS = ("unit", "full_scale_dbm", "format", "labels", "count")
_RUN_FIELDS = ("rid", "start_time", "file")
_SOURCE_KEYS = ("files", "root", "subscan", "columns")
_IMPORT_OPTIONS = ("complete_only", "skip_bad_files", "max_dataset_bytes")


@dataclass(frozen=True)
class ColumnSpec:
    """Where one campaign column comes from in each results file of a source."""

    column: str
    source: str
    name: object
    key: str
    line: int | None = None
    unit: str | None = None
    full_scale_dbm: float | None = None
    format: str | None = None
    labels: dict | None = None
    count: object = None
    expression: Expression | None = None
    placeholders: tuple = ()

    def filled(self, key: dict) -> ColumnSpec:
        """This column for one match of its name pattern (placeholders replaced)."""
        if not self.placeholders:
            return self
        if self.expression is not None:
            e = self.expression.filled(key)
            return replace(self, name=e.text, expression=e, placeholders=())
        return replace(self, name=fill(self.name, key), placeholders=())

    def where(self) -> str:
        """The mapping key of this column and its line, for messages:
        ``mapping key '...' (line N)``."""
        return f"mapping key '{self.key}'" + (f" (line {self.line})" if self.line else "")


@dataclass(frozen=True)
class SourceSpec:
    """One entry of a table: its files and its columns."""

    table: str
    index: int
    files: tuple
    root: str | None
    columns: dict
    key: str
    line: int | None = None
    files_line: int | None = None
    placeholders: tuple = ()
    subscan: str | None = None


@dataclass(frozen=True)
class Mapping:
    """A read and checked mapping file."""

    path: Path
    campaign: dict
    sources: tuple
    complete_only: bool = False
    text: str = field(default="", repr=False)
    skip_bad_files: bool = False
    max_dataset_bytes: int | None = None

    @property
    def folder(self) -> Path:
        """The folder of the mapping file: relative ``files`` patterns are resolved against it."""
        return self.path.parent


def read_mapping(path) -> Mapping:
    """Read and check a mapping file (module doc); InputError naming key and line."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(f"mapping cannot be read ({exc.strerror})", file=str(path)) from None
    except UnicodeDecodeError:
        raise InputError("mapping is not UTF-8 text", file=str(path)) from None
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"mapping is not valid TOML ({exc})", file=str(path)) from None
    lines = _Lines(text)
    err = _Errors(str(path), lines)
    for k in doc:
        if k not in ("import", "campaign", *TABLE_COLUMNS):
            err.unknown(k, k, ("import", "campaign", *TABLE_COLUMNS), "top-level key")
    opts = doc.get("import", {})
    err.table(opts, "import")
    for k in opts:
        if k not in _IMPORT_OPTIONS:
            err.unknown(f"import.{k}", k, _IMPORT_OPTIONS, "key of [import]")
    for k in ("complete_only", "skip_bad_files"):
        if not isinstance(opts.get(k, False), bool):
            err.bad(f"import.{k}", "must be true or false")
    limit = opts.get("max_dataset_bytes")
    if limit is not None and (isinstance(limit, bool) or not isinstance(limit, int)
                              or limit < 1):
        err.bad("import.max_dataset_bytes", "must be a whole number of bytes, at least 1")
    complete_only = opts.get("complete_only", False)
    campaign = doc.get("campaign", {})
    err.table(campaign, "campaign")
    for k in campaign:
        if k not in CAMPAIGN_KEYS:
            err.unknown(f"campaign.{k}", k, CAMPAIGN_KEYS, "campaign.json key")
    sources = []
    for table in TABLE_COLUMNS:
        entries = doc.get(table, [])
        if isinstance(entries, dict):
            entries = [entries]
        if not isinstance(entries, list):
            err.bad(table, "must be a table ([[%s]] entries)" % table)
        for i, entry in enumerate(entries):
            sources.append(_source(table, i, entry, err))
    if not sources:
        err.bad("", "maps no campaign table (expected [[calibration_amplitude]], ...)")
    if not any(s.table == "calibration_amplitude" for s in sources):
        err.bad("", "has no [[calibration_amplitude]]: every analysis needs the amplitude "
                "calibration")
    return Mapping(path=path, campaign=campaign, sources=tuple(sources),
                   complete_only=complete_only, text=text,
                   skip_bad_files=opts.get("skip_bad_files", False), max_dataset_bytes=limit)


def _source(table: str, i: int, entry, err) -> SourceSpec:
    key = f"{table}[{i + 1}]"
    err.table(entry, key, table)
    for k in entry:
        if k not in _SOURCE_KEYS:
            err.unknown(f"{key}.{k}", k, _SOURCE_KEYS, f"key of [[{table}]]", table, k)
    files = entry.get("files")
    if isinstance(files, str):
        files = [files]
    if not files or not all(isinstance(f, str) and f.strip() for f in files):
        err.bad(f"{key}.files", "must be a glob or a list of globs of results files", table)
    root = entry.get("root")
    if root is not None and not isinstance(root, str):
        err.bad(f"{key}.root", "must be a string (an ndscan root prefix)", table)
    subscan = entry.get("subscan")
    if subscan is not None and not (isinstance(subscan, str) and subscan):
        err.bad(f"{key}.subscan", "must be a string (the name of an ndscan subscan)", table)
    cols = entry.get("columns", {})
    err.table(cols, f"{key}.columns", table)
    required, optional = TABLE_COLUMNS[table]
    for c in cols:
        if c not in required + optional:
            err.unknown(f"{key}.columns.{c}", c, required + optional, f"column of {table}",
                        table, c)
    columns = {c: _column(c, v, f"{key}.columns.{c}", err, table, i) for c, v in cols.items()}
    keys = _placeholders(columns, required + optional, key, err, table)
    given = set(cols) | set(keys)
    missing = [c for c in required if c not in given]
    if table == "populations" and "n_even" not in given and not {"n00", "n11"} <= given:
        missing.append("n_even (or n00 and n11)")
    if missing:
        err.bad(f"{key}.columns", f"misses the column(s) {', '.join(missing)}", table)
    return SourceSpec(table=table, index=i, files=tuple(files), root=root, columns=columns,
                      key=key, line=err.lines.find(table, None, i),
                      files_line=err.lines.find(table, "files", i), placeholders=keys,
                      subscan=subscan)


def _placeholders(columns: dict, known: tuple, key: str, err, table: str) -> tuple:
    """The placeholders of a source's name patterns: each a column of the table that
    the source does not give otherwise, and the same in every pattern."""
    patterned = {c: s.placeholders for c, s in columns.items() if s.placeholders}
    if not patterned:
        return ()
    first, keys = next(iter(patterned.items()))
    for c, ks in patterned.items():
        for k in ks:
            if k not in known:
                err.unknown(f"{key}.columns.{c}", k, known, f"placeholder (a column of {table})",
                            table, c)
            if k in columns:
                err.bad(f"{key}.columns.{c}", f"placeholder '{{{k}}}' names the column {k}, "
                        "which this source also gives: drop one", table, c)
        if set(ks) != set(keys):
            err.bad(f"{key}.columns.{c}", f"its placeholders ({', '.join(ks)}) differ from "
                    f"those of {first} ({', '.join(keys)})", table, c)
    return keys


def _column(column: str, v, key: str, err, table: str, index: int) -> ColumnSpec:
    line = err.lines.find(table, column, index)
    if not isinstance(v, dict):
        return ColumnSpec(column, "value", v, key, line)
    for k in v:
        if k not in SOURCES + MODIFIERS:
            err.unknown(f"{key}.{k}", k, SOURCES + MODIFIERS, "column key", table, column)
    src = [k for k in SOURCES if k in v]
    if len(src) != 1:
        err.bad(key, f"needs exactly one of {', '.join(SOURCES)}; got "
                f"{', '.join(src) or 'none'}", table, column)
    source, name = src[0], v[src[0]]
    if source not in ("value",) and not isinstance(name, str):
        err.bad(f"{key}.{source}", "must be a name (a string)", table, column)
    if source == "run" and name not in _RUN_FIELDS:
        err.bad(f"{key}.run", f"must be one of {', '.join(_RUN_FIELDS)}, got '{name}'",
                table, column)
    expression, keys = None, placeholders(name)
    if source == "expr":
        try:
            expression = parse_expression(name)
        except ExpressionError as exc:
            err.bad(f"{key}.expr", str(exc), table, column)
        keys = tuple(dict.fromkeys(k for _, n in expression.references
                                   for k in placeholders(n)))
    elif source in ("value", "run", "argument", "parameter"):
        keys = ()
    unit = v.get("unit")
    if unit is not None and not isinstance(unit, str):
        err.bad(f"{key}.unit", "must be a string", table, column)
    count = v.get("count")
    if count is not None and not (count == "all" or isinstance(count, int)
                                  or (isinstance(count, list)
                                      and all(isinstance(c, int) for c in count))):
        err.bad(f"{key}.count", "must be an integer outcome, a list of them, or \"all\"",
                table, column)
    labels = v.get("labels")
    if labels is not None and not isinstance(labels, dict):
        err.bad(f"{key}.labels", "must be a table { code = \"name\" }", table, column)
    fs = v.get("full_scale_dbm")
    if fs is not None and not isinstance(fs, (int, float)):
        err.bad(f"{key}.full_scale_dbm", "must be a number", table, column)
    if column not in COLUMN_KINDS:            # pragma: no cover - TABLE_COLUMNS is checked
        err.bad(key, "no unit rule for this column", table, column)
    return ColumnSpec(column, source, name, key, line, unit=unit,
                      full_scale_dbm=None if fs is None else float(fs), format=v.get("format"),
                      labels=labels, count=count, expression=expression,
                      placeholders=keys)


class _Lines:
    """Line numbers of a mapping's tables and keys, for messages (tomllib gives none)."""

    def __init__(self, text: str):
        self.text = text.splitlines()

    def find(self, table: str, key: str | None = None, index: int = 0) -> int | None:
        """The line of ``key`` in the ``index``-th ``[[table]]`` entry (or of the entry's
        header; or of ``[table]``/``table = ...``); None when not found."""
        entry = re.compile(r"^\s*\[\[\s*" + re.escape(table) + r"\s*\]\]")
        header = re.compile(r"^\s*\[\[?\s*" + re.escape(table) + r"(\.[\w.]+)?\s*\]\]?")
        other = re.compile(r"^\s*\[")
        keyline = None if key is None else re.compile(r"^\s*" + re.escape(key) + r"\s*=")
        seen, start, inside = -1, None, False
        for i, line in enumerate(self.text, 1):
            if entry.match(line):
                seen += 1
                inside = seen == index
                if inside and start is None:
                    start = i
            elif header.match(line):
                inside = seen <= 0 and index == 0 or seen == index
                if inside and start is None:
                    start = i
            elif other.match(line):
                inside = False
            elif start is None and re.match(r"^\s*" + re.escape(table) + r"\s*=", line):
                start = i
            if inside and keyline is not None and keyline.match(line):
                return i
        return start


class _Errors:
    def __init__(self, file: str, lines: _Lines):
        self.file, self.lines = file, lines

    def _raise(self, key: str, msg: str, table=None, column=None):
        m = re.match(r"^(\w+)(?:\[(\d+)\])?", key or "")
        index = int(m.group(2)) - 1 if m and m.group(2) else 0
        line = self.lines.find(table or (m.group(1) if m else key), column, index)
        where = f"key '{key}'" if key else "mapping"
        where += f" (line {line})" if line else ""
        raise InputError(f"{where}: {msg}", file=self.file)

    def bad(self, key, msg, table=None, column=None):
        self._raise(key, msg, table, column)

    def unknown(self, key, name, known, what, table=None, column=None):
        near = difflib.get_close_matches(str(name), [str(k) for k in known], n=1)
        hint = f" (did you mean '{near[0]}'?)" if near else ""
        self._raise(key, f"unknown {what} '{name}'{hint}", table,
                    column if column else (name if table else None))

    def table(self, v, key, table=None):
        if not isinstance(v, dict):
            self._raise(key, "must be a table", table)
