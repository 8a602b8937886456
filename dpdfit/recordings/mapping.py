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
  subscan of that root: one row per inner point, :mod:`.ndscan_scan`).

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

Any key dpdfit does not know, and a value of the wrong type (a string where a
number or ``true``/``false`` belongs, an integer beyond int64), is an error naming
the key and its line.
"""

from __future__ import annotations

import sys
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path

from dpdfit.errors import InputError

from .columns import CAMPAIGN_TABLES
from .expressions import Expression, ExpressionError, parse_expression
from .input_files import read_input_text
from .mapping_lines import KeyLines, MappingErrors
from .mapping_values import check_campaign_types, check_constant, column_modifiers, shown
from .name_patterns import fill, placeholders, repeated_placeholder
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


def read_mapping(path, *, partial: bool = False) -> Mapping:
    """Read and check a mapping file (module doc); InputError naming key and line.

    ``partial``: the mapping of further recordings (``dpdfit add``), which may map any
    subset of the tables (a campaign's mapping needs ``[[calibration_amplitude]]``)."""
    path = Path(path)
    # a regular file of at most MAX_INPUT_BYTES: a FIFO or a device is refused, not read
    text = read_input_text(path, what="mapping")
    doc = _toml(text, str(path))
    err = MappingErrors(str(path), KeyLines(text))
    for k in doc:
        if k not in ("import", "campaign", *TABLE_COLUMNS):
            err.unknown(k, k, ("import", "campaign", *TABLE_COLUMNS), "top-level key")
    opts = doc.get("import", {})
    err.table(opts, "import")
    for k in opts:
        if k not in _IMPORT_OPTIONS:
            err.unknown(f"import.{k}", k, _IMPORT_OPTIONS, "key of [import]", "import")
    for k in ("complete_only", "skip_bad_files"):
        if not isinstance(opts.get(k, False), bool):
            err.bad(f"import.{k}", f"must be true or false, got {shown(opts[k])}", "import", k)
    limit = opts.get("max_dataset_bytes")
    if limit is not None and (isinstance(limit, bool) or not isinstance(limit, int)
                              or limit < 1):
        err.bad("import.max_dataset_bytes", "must be a whole number of bytes, at least 1, "
                f"got {shown(limit)}", "import", "max_dataset_bytes")
    complete_only = opts.get("complete_only", False)
    campaign = doc.get("campaign", {})
    err.table(campaign, "campaign")
    for k in campaign:
        if k not in CAMPAIGN_KEYS:
            err.unknown(f"campaign.{k}", k, CAMPAIGN_KEYS, "campaign.json key", "campaign")
    check_campaign_types(campaign, err)
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
    if not partial and not any(s.table == "calibration_amplitude" for s in sources):
        err.bad("", "has no [[calibration_amplitude]]: every analysis needs the amplitude "
                "calibration")
    return Mapping(path=path, campaign=campaign, sources=tuple(sources),
                   complete_only=complete_only, text=text,
                   skip_bad_files=opts.get("skip_bad_files", False), max_dataset_bytes=limit)


def _toml(text: str, file: str) -> dict:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"mapping is not valid TOML ({exc})", file=file) from None
    except ValueError:
        # tomllib converts an integer with int(), which refuses more digits than this
        raise InputError(f"mapping is not valid TOML (an integer of more than "
                         f"{sys.get_int_max_str_digits()} digits)", file=file) from None
    except RecursionError:
        raise InputError("mapping is not valid TOML (arrays or tables nested too deeply "
                         "to read)", file=file) from None


def _source(table: str, i: int, entry, err) -> SourceSpec:
    key = f"{table}[{i + 1}]"
    err.table(entry, key, table)
    for k in entry:
        if k not in _SOURCE_KEYS:
            err.unknown(f"{key}.{k}", k, _SOURCE_KEYS, f"key of [[{table}]]", table, k)
    files = entry.get("files")
    if isinstance(files, str):
        files = [files]
    if not isinstance(files, list) or not files \
            or not all(isinstance(f, str) and f.strip() for f in files):
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
        check_constant(column, v, key, err, table)
        return ColumnSpec(column, "value", v, key, line)
    for k in v:
        if k not in SOURCES + MODIFIERS:
            err.unknown(f"{key}.{k}", k, SOURCES + MODIFIERS, "column key", table, column)
    src = [k for k in SOURCES if k in v]
    if len(src) != 1:
        err.bad(key, f"needs exactly one of {', '.join(SOURCES)}; got "
                f"{', '.join(src) or 'none'}", table, column)
    source, name = src[0], v[src[0]]
    if source == "value":
        check_constant(column, name, f"{key}.value", err, table)
    elif not isinstance(name, str):
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
    names = [n for _, n in expression.references] if expression else [name]
    for n in names if keys else ():
        if (twice := repeated_placeholder(n)) is not None:
            err.bad(f"{key}.{source}", f"the placeholder '{{{twice}}}' appears twice in '{n}' "
                    "(each is read once from a name)", table, column)
    if column not in COLUMN_KINDS:            # pragma: no cover - TABLE_COLUMNS is checked
        err.bad(key, "no unit rule for this column", table, column)
    return ColumnSpec(column, source, name, key, line, expression=expression,
                      placeholders=keys, **column_modifiers(column, v, key, err, table))
