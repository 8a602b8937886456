"""Cells a spreadsheet would run as a formula: the one rule, for the tables dpdfit reads
and for those it writes.

Labs open dpdfit's CSV files in spreadsheets, which run a text cell as a formula when it
starts with ``=``, ``+``, ``-`` or ``@`` (spaces before them aside), a tab or a carriage
return (OWASP, "CSV injection": ``=cmd|' /C calc'!A0``).  A number is no formula:
``-1.5``, ``+3e-4`` and ``-inf`` are written and read as they are.

The rule is applied twice: a table from elsewhere holding such a cell is refused when it
is read (:mod:`dpdfit.recordings.csv_text`), and no output table is written with one
(:func:`dpdfit.recordings.outputs.refuse_formula_cells`, the last guard for a cell made
from another kind of input, such as an imported results file's value or name).
"""

from __future__ import annotations

import re

__all__ = ["FORMULA_STARTS", "starts_like_formula", "is_number", "runs_as_formula",
           "first_formula_cell"]

#: the first characters of a cell a spreadsheet runs as a formula: after spaces
#: ``= + - @``; a tab or a carriage return at the very start
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")
_START = re.compile(r"^(?:[\t\r]| *[=+\-@])")


def starts_like_formula(text: str) -> bool:
    """``text`` starts as a formula does (:data:`FORMULA_STARTS`), number or not."""
    return _START.match(text) is not None


def is_number(text: str) -> bool:
    """``text`` is a number (``float`` reads it: ``-1.5``, ``+3e-4``, ``-inf``)."""
    try:
        float(text)
    except ValueError:
        return False
    return True


def runs_as_formula(value) -> bool:
    """``value`` is a text cell a spreadsheet would run as a formula: a string that starts
    like one (:func:`starts_like_formula`) and is not a number."""
    return isinstance(value, str) and starts_like_formula(value) and not is_number(value)


def first_formula_cell(cells) -> int | None:
    """The position (0-based) of the first cell of the column ``cells`` (a pandas Series)
    that :func:`runs_as_formula`, None when there is none.  A column of numbers, times or
    booleans holds no text; of the others each distinct value is looked at once."""
    if cells.dtype.kind in "biufcmM":
        return None
    bad = [v for v in cells.unique() if runs_as_formula(v)]
    if not bad:
        return None
    return int(cells.isin(bad).to_numpy(dtype=bool).argmax())
