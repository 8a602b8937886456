"""``benchmark`` role: one value of a benchmark record, cited in prose.

A speed, memory or ratio figure in the documentation is never typed: prose cites it
from the record that measured it, read when the documentation is built::

    the sweep takes {benchmark}`sweep_speed.json::quantity~median wall::value::.2g` s

The text has three or four fields separated by ``::``:

``FILE``
    a file in ``benchmarks/`` (any file the ``benchmark-table`` directive reads:
    a record written with ``--json``, or a harness, validation or scale report);
``ROW``
    which row: ``#N`` (the N-th row, from 0), or one or more ``key=value`` (exact)
    or ``key~text`` (the cell contains the text) joined by ``&``; the selector must
    match exactly one row;
``COLUMN``
    the column (row key) whose value is shown;
``FORMAT`` (optional)
    a Python format specification (``.2g``, ``.0f``, ``,.0f``); without it the value
    is shown as the Benchmarks page shows it (4 significant digits).

The value links to the Benchmarks page.  A file, row or column that does not exist,
a selector matching several rows, or a value that is not a number, is an error:
the build fails (the documentation is built with ``-W``).  The file is a dependency
of the page, so a new record changes the page on the next build.
"""

from __future__ import annotations

import os
from pathlib import Path

from docutils import nodes
from sphinx import addnodes
from sphinx.util.docutils import SphinxRole

from benchmark_tables import RecordError, fmt, load_record

__all__ = ["BenchmarkValue", "BenchmarkValueError", "lookup", "format_value", "setup"]

#: between the fields (``|`` would split a Markdown table's cell, ``:`` occurs in rows)
SEP = "::"

#: where the records are, relative to the documentation's source folder
RECORDS = Path("..") / "benchmarks"


class BenchmarkValueError(ValueError):
    """A citation that does not name one value of one record (the message says why)."""


def _matches(row: dict, term: str) -> bool:
    if "~" in term and ("=" not in term or term.index("~") < term.index("=")):
        key, _, text = term.partition("~")
        return key.strip() in row and text.strip() in str(row[key.strip()])
    key, sep, value = term.partition("=")
    if not sep:
        raise BenchmarkValueError(f"row selector {term!r}: use #N, key=value or key~text")
    return key.strip() in row and str(row[key.strip()]) == value.strip()


def select_row(rows: list[dict], selector: str) -> dict:
    """The one row of ``rows`` that ``selector`` names."""
    selector = selector.strip()
    if selector.startswith("#"):
        try:
            return rows[int(selector[1:])]
        except (ValueError, IndexError):
            raise BenchmarkValueError(f"row {selector!r}: the record has {len(rows)} rows "
                                      "(#0 is the first)") from None
    terms = [t for t in selector.split("&") if t.strip()]
    if not terms:
        raise BenchmarkValueError("empty row selector")
    found = [r for r in rows if all(_matches(r, t) for t in terms)]
    if len(found) != 1:
        raise BenchmarkValueError(f"row selector {selector!r} matches {len(found)} rows "
                                  "(it must match exactly one)")
    return found[0]


def lookup(path, selector: str, column: str) -> float:
    """The number in column ``column`` of the row ``selector`` names in the file ``path``."""
    try:
        rec = load_record(path)
    except RecordError as exc:
        raise BenchmarkValueError(str(exc)) from exc
    row = select_row(rec["rows"], selector)
    column = column.strip()
    if column not in row:
        raise BenchmarkValueError(f"{path}: row {selector!r} has no column {column!r} "
                                  f"(columns: {', '.join(map(repr, row))})")
    value = row[column]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise BenchmarkValueError(f"{path}: row {selector!r}, column {column!r} is "
                                  f"{value!r}, not a number")
    return value


def format_value(value: float, spec: str | None) -> str:
    """``value`` as shown in prose: with ``spec`` if given, else as on the Benchmarks page."""
    if not spec:
        return fmt(value)
    try:
        return format(value, spec.strip())
    except ValueError as exc:
        raise BenchmarkValueError(f"format {spec!r}: {exc}") from None


def parse(text: str) -> tuple[str, str, str, str | None]:
    """(file, row selector, column, format or None) of a role's text."""
    parts = [p.strip() for p in text.split(SEP)]
    if len(parts) not in (3, 4) or not all(parts[:3]):
        raise BenchmarkValueError(f"{text!r}: expected FILE::ROW::COLUMN[::FORMAT]")
    return parts[0], parts[1], parts[2], (parts[3] if len(parts) == 4 else None)


class BenchmarkValue(SphinxRole):
    """``{benchmark}`FILE::ROW::COLUMN[::FORMAT]```: the value, linked to the Benchmarks page."""

    def run(self):
        try:
            name, selector, column, spec = parse(self.text)
            _, path = self.env.relfn2path(str(RECORDS / name), "index")
            if not os.path.isfile(path):
                raise BenchmarkValueError(f"benchmark file not found: benchmarks/{name}")
            self.env.note_dependency(path)
            shown = format_value(lookup(path, selector, column), spec)
        except BenchmarkValueError as exc:
            msg = self.inliner.reporter.error(f"benchmark role: {exc}", line=self.lineno)
            return [self.inliner.problematic(self.rawtext, self.rawtext, msg)], [msg]
        ref = addnodes.pending_xref("", refdomain="std", reftype="doc",
                                    reftarget="/benchmarks", refexplicit=True,
                                    refwarn=True)
        ref += nodes.inline(shown, shown, classes=["benchmark-value"])
        return [ref], []


def setup(app):
    """Register the ``benchmark`` role."""
    app.add_role("benchmark", BenchmarkValue())
    return {"parallel_read_safe": True, "parallel_write_safe": True}
