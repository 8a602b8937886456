"""A CSV file's bytes -> a table of strings, its header and every row checked first.

The one parser of the recordings' CSV text (:func:`dpdfit.recordings.tables.read_csv_strings`
reads the file through :mod:`dpdfit.recordings.input_files` and hands its bytes here).
A table a lab writes has one header line naming each column once and rows no wider than
it; a file that is not such a table is damaged or crafted, and is refused as a whole
(:class:`~dpdfit.errors.RefusedFileError`, naming the file, the column and the row):

* a NUL byte: binary data, or a sparse file read as zeros;
* a header wider than :data:`~dpdfit.core.defaults.MAX_CSV_COLUMNS`, refused before the
  table is built (pandas takes minutes and gigabytes over a row of 10^5 fields);
* a column named twice (after stripping spaces): pandas would rename the second ``a.1``
  and keep both;
* a row with more fields than the header: pandas would drop a field silently, or take the
  first column as the index.  The rows are parsed against the header's width (the header
  is parsed as a row of its own), so that the tokenizer refuses the first wider row
  where it meets it, and that refusal is turned into a line naming the row;
* a text cell that a spreadsheet would run as a formula (OWASP, "CSV injection"): it starts
  with ``=``, ``+``, ``-``, ``@`` (spaces before them aside), a tab or a carriage return, and
  is not a number (``-1.5``, ``+3`` and ``-inf`` are numbers, so they pass).  The cell
  would be copied into the CSV files dpdfit writes, which labs open in spreadsheets: it is
  refused on input, never written.

Comment lines (``#`` at column 1) and blank lines are skipped, as
:func:`dpdfit.errors.data_line` counts them.  An honest file gives the same table as
``pandas.read_csv(comment="#", skipinitialspace=True, dtype=str, keep_default_na=False)``
with its column names stripped.
"""

from __future__ import annotations

import io
import re
import warnings

import numpy as np
import pandas as pd

from dpdfit.core.defaults import MAX_CSV_COLUMNS
from dpdfit.errors import InputError, RefusedFileError

from .formula_cells import FORMULA_STARTS, first_formula_cell, starts_like_formula

__all__ = ["parse_csv_strings", "parse_csv_table", "header_line", "header_names", "FORMULA_STARTS"]

#: a number as a lab writes it (ASCII; ``float`` accepts all of these)
_NUMBER = (rb"(?:(?:\d+\.?\d*|\.\d+)(?:[eE][+\-]?\d+)?"
           rb"|[iI][nN][fF](?:[iI][nN][iI][tT][yY])?|[nN][aA][nN])")
#: in the raw bytes (after a line break or comma; spaces and a quote aside), a cell that
#: may be a formula: it starts with ``= @``, a tab or a carriage return (not a line's
#: end), or with a sign not followed by a number that ends the cell.  Every cell
#: :func:`_check_formulas` refuses (:func:`~.formula_cells.runs_as_formula`) starts so: a file without a match (nearly every honest
#: one) is not looked at cell by cell, which is slower still (the scan adds a third to
#: the reading of a table of 10^6 rows of negative numbers)
_MAYBE_FORMULA = re.compile(rb'[,\n][ ]*"?[ ]*(?:[=@\t]|\r(?!\n)|[+\-](?!' + _NUMBER
                            + rb'[ ]*"?[ ]*(?:[,\r\n#]|$)))')
#: pandas' C tokenizer on a row wider than the first
_TOO_MANY = re.compile(r"Expected (\d+) fields in line (\d+), saw (\d+)")


def _lines(raw: bytes):
    """``(line number, line)`` of ``raw``'s lines, 1-based, without their line break."""
    start, number = 0, 1
    while start < len(raw):
        end = raw.find(b"\n", start)
        end = len(raw) if end < 0 else end
        yield number, raw[start:end].rstrip(b"\r")
        start, number = end + 1, number + 1


def _skipped(line: bytes) -> bool:
    """A line the parser skips: ``#`` at column 1, or blank (as ``errors.data_line``)."""
    return line.startswith(b"#") or not line.strip()


def header_line(raw: bytes, name: str, whole: bool = True) -> tuple[int, bytes] | None:
    """``(line number, text)`` of the header of the CSV bytes ``raw`` (a leading UTF-8
    byte-order mark dropped), None when every line is skipped; a RefusedFileError naming
    ``name`` when the header has more than ``MAX_CSV_COLUMNS`` fields.  Only the header's
    line is looked at.  ``whole=False``: ``raw`` is the start of the file, and a header
    not yet ended by a line break is None (read on), unless already too wide."""
    if raw.startswith(b"\xef\xbb\xbf"):
        raw = raw[3:]
    for number, line in _lines(raw):
        if _skipped(line):
            continue
        # commas in quotes, or after a '#', count too: an upper bound, exact for a header
        # that a lab writes
        fields = line.count(b",") + 1
        if fields > MAX_CSV_COLUMNS:
            raise RefusedFileError(f"the header (line {number}) has {fields} fields, more "
                                   f"than the {MAX_CSV_COLUMNS} columns dpdfit reads from "
                                   "one table", file=name)
        if not whole and not raw.endswith(b"\n") and raw.rstrip(b"\r").endswith(line):
            return None                        # the header's line goes on
        return number, line
    return None


def header_names(line: bytes, name: str) -> list[str]:
    """The column names of the header's ``line`` (:func:`header_line`) as
    :func:`parse_csv_strings` names the columns (a RefusedFileError as it refuses them)."""
    try:
        row = pd.read_csv(io.BytesIO(line), header=None, comment="#", skipinitialspace=True,
                          dtype=str, keep_default_na=False, nrows=1)
    except (pd.errors.EmptyDataError, pd.errors.ParserError, UnicodeDecodeError):
        raise InputError("the header cannot be read as CSV", file=name) from None
    return _names(row.iloc[0], name)


def _row_at(raw: bytes, line: int) -> int:
    """The data row (1-based, the header not counted) that line ``line`` of ``raw`` holds."""
    row = -1                                      # the header is the first line counted
    for number, text in _lines(raw):
        if number == 1 and text.startswith(b"\xef\xbb\xbf"):
            text = text[3:]
        if not _skipped(text):
            row += 1
        if number >= line:
            break
    return max(row, 1)


def _names(header: pd.Series, name: str) -> list[str]:
    """The column names of the header row, stripped (``Unnamed: i`` for an empty one, as
    pandas names it); a RefusedFileError for a name given twice or a formula."""
    names, seen = [], {}
    for i, text in enumerate(header.tolist()):
        text = "" if not isinstance(text, str) else text
        if starts_like_formula(text):          # a name is refused even as a number
            raise RefusedFileError(f"the header's column {i + 1} starts like a spreadsheet "
                                   "formula: dpdfit does not read such a name (a "
                                   "spreadsheet opening its outputs would run it)",
                                   file=name, column=text.strip())
        col = text.strip() or f"Unnamed: {i}"
        if col in seen:
            raise RefusedFileError(f"is named twice in the header (columns {seen[col] + 1} "
                                   f"and {i + 1}): which one holds the values?",
                                   file=name, column=col)
        seen[col] = i
        names.append(col)
    return names


def _check_formulas(df: pd.DataFrame, raw: bytes, name: str) -> None:
    """Refuse the first text cell (column by column, then row) a spreadsheet would run
    (:func:`~.formula_cells.runs_as_formula`)."""
    if not _MAYBE_FORMULA.search(raw):        # a data cell follows a line break or comma
        return
    for col in df.columns:
        i = first_formula_cell(df[col])
        if i is not None:
            first = str(df[col].iloc[i]).lstrip(" ")[:1]
            raise RefusedFileError(
                f"the cell starts with {first!r} and is not a number: a spreadsheet would "
                "run it as a formula, so dpdfit does not read it (its outputs are opened "
                "in spreadsheets)", file=name, column=col, row=i + 1)


def parse_csv_strings(raw: bytes, name: str) -> pd.DataFrame:
    """The CSV bytes ``raw`` of file ``name`` as a table of strings, its header and rows
    checked (module doc).  InputError naming ``name`` when it is empty or not CSV text;
    RefusedFileError when it is not a table a lab writes."""
    nul = raw.find(b"\0")
    if nul >= 0:
        raise RefusedFileError(f"holds a NUL byte (byte {nul + 1}): not a text table (a "
                               "binary file, or a sparse file read as zeros?)", file=name)
    if header_line(raw, name) is None:
        raise InputError("file is empty (no header, no data)", file=name)
    try:
        # the header parsed as a row: every row is checked against its width
        df = pd.read_csv(io.BytesIO(raw), header=None, comment="#", skipinitialspace=True,
                         dtype=str, keep_default_na=False)
    except pd.errors.EmptyDataError:
        raise InputError("file is empty (no header, no data)", file=name) from None
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        text = str(exc).strip()
        wide = _TOO_MANY.search(text)
        if wide:
            n, line, saw = (int(g) for g in wide.groups())
            raise RefusedFileError(f"the row has {saw} fields, the header {n}: a field the "
                                   "header does not name (a stray comma?)", file=name,
                                   row=_row_at(raw, line)) from None
        msg = text.splitlines()[-1] if text else type(exc).__name__
        raise InputError(f"not a readable CSV file ({msg})", file=name) from None
    names = _names(df.iloc[0], name)
    df = df.iloc[1:].reset_index(drop=True)
    df.columns = names
    _check_formulas(df, raw, name)
    return df


def parse_csv_table(raw: bytes, name: str, numbers=()) -> pd.DataFrame:
    """The CSV bytes ``raw`` of file ``name`` as :func:`parse_csv_strings` reads them, but
    with each column named in ``numbers`` as float64 when every one of its cells is a
    finite number: the same table, the same refusals, after the numbers are converted.

    Why not strings first: a cell held as a Python string costs about 60 bytes, a float 8,
    so a calibration table of 10^6 rows held as text needs several times the file's bytes.
    The columns are parsed as numbers directly (pandas' C tokenizer, correctly rounded as
    ``float`` reads them), the header and the width of every row checked as
    :func:`parse_csv_strings` checks them.  A file where that does not go through -- a cell
    that is not a finite number, a row narrower or wider than the header, any doubt -- is
    parsed again by :func:`parse_csv_strings`, which then refuses or accepts it exactly as
    before and names the place: an honest table pays one parse, a damaged one two."""
    table = _parse_numbers_directly(raw, name, numbers)
    return parse_csv_strings(raw, name) if table is None else table


def _parse_numbers_directly(raw: bytes, name: str, numbers) -> pd.DataFrame | None:
    """The table with its number columns as float64, or None when the file needs the
    string parse (:func:`parse_csv_table`)."""
    if not numbers or raw.find(b"\0") >= 0:
        return None
    header = header_line(raw, name)
    if header is None:
        return None
    try:
        names = header_names(header[1], name)
    except InputError:                       # refused with its row by the string parse
        return None
    floats = [c for c in names if c in set(numbers)]
    if not floats:
        return None
    dtype = {c: ("float64" if c in floats else str) for c in names}
    try:
        with warnings.catch_warnings():
            # a first row wider than the header: pandas warns and drops a field
            warnings.simplefilter("error", pd.errors.ParserWarning)
            df = pd.read_csv(io.BytesIO(raw), header=0, names=names, index_col=False,
                             comment="#", skipinitialspace=True, dtype=dtype,
                             keep_default_na=False)
    except (ValueError, pd.errors.ParserError, pd.errors.ParserWarning,
            pd.errors.EmptyDataError, UnicodeDecodeError, OverflowError):
        return None
    if len(df) == 0:
        return None
    for c in floats:
        # a missing field of a short row is NaN; nan or inf written: the string parse
        # names the row and says which
        if not np.isfinite(df[c].to_numpy()).all():
            return None
    for c in names:
        if c not in floats and df[c].isna().any():      # a short row
            return None
    _check_formulas(df, raw, name)
    return df
