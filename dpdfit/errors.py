"""Exceptions raised by dpdfit.

Every error a user can trigger with bad input is a :class:`DpdfitError`; its
message is one line that says what is wrong and where (file, column, row).
The command line prints that line and exits with a non-zero status.

Rows are data rows: row 1 is the first line after the CSV header, not counting
``#`` comment lines and blank lines (which the readers skip).  When the file is
a text table on disk, the message also gives the line of the file that holds
the row, ``(line N)``, so that an editor can jump there (:func:`data_line`).
"""

from __future__ import annotations

import os
import re

__all__ = ["DpdfitError", "InputError", "ImplausibleValueError", "RefusedFileError", "FitError",
           "NotInvertibleError", "data_line", "printable"]

#: Files larger than this are not scanned for a row's line number (the message keeps the row).
_MAX_SCAN_BYTES = 200_000_000


#: numpy's repr of a scalar (numpy 2: ``np.float64(0.5)``, ``np.int64(3)``, ``np.str_('a')``)
_NUMPY_REPR = re.compile(r"\bnp\.(?:u?int\d*|float\d*|complex\d*|bool_?|str_|bytes_)"
                         r"\(([^()]*)\)")


def printable(text: str) -> str:
    """``text`` as a person reads it on a terminal: numbers as written (a numpy scalar's
    repr, ``np.int64(3)``, as ``3``) and every character that is not printable -- a
    control character, an escape sequence's ESC, a line break -- escaped (``\\x1b``),
    so that a message quoting a crafted file stays one line and cannot drive the
    terminal."""
    text = _NUMPY_REPR.sub(r"\1", str(text))
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def _skipped(line: str) -> bool:
    """A line the CSV readers skip: a ``#`` comment at column 1, or blank (spaces only)."""
    return line.startswith("#") or not line.strip()


def _is_number_line(line: str) -> bool:
    """All comma-separated fields are numbers: a headerless table's first data line."""
    try:
        for field in line.split("#", 1)[0].split(","):
            float(field)
    except ValueError:
        return False
    return True


def data_line(path, row: int) -> int | None:
    """The 1-based line of text file ``path`` that holds data row ``row`` (or None).

    Counts lines as the CSV readers do (``pandas.read_csv(comment="#")``):
    lines starting with ``#`` and blank lines are skipped, the first remaining
    line is the header unless all its fields are numbers (a headerless trace).
    None when ``path`` is not a readable text file or has fewer rows.
    """
    try:
        row = int(row)
        if row < 1 or not os.path.isfile(path) or os.path.getsize(path) > _MAX_SCAN_BYTES:
            return None
        with open(path, "rb") as fh:
            if b"\0" in fh.read(4096):
                return None          # binary (.npy, .npz): rows are sample indices
        n, header = 0, None
        with open(path, encoding="utf-8", errors="replace") as fh:
            for lineno, line in enumerate(fh, 1):
                if lineno == 1:
                    line = line.lstrip("\ufeff")
                if _skipped(line):
                    continue
                if header is None:
                    header = not _is_number_line(line)
                    if header:
                        continue
                n += 1
                if n == row:
                    return lineno
    except (OSError, ValueError, TypeError):
        return None
    return None


class DpdfitError(ValueError):
    """Base class of all errors that dpdfit reports to the user."""


class InputError(DpdfitError):
    """Bad input data: missing column, NaN, out-of-range value, empty file, ...

    Parameters
    ----------
    message : str
        What is wrong.
    file, column : str, optional
        Where. ``row`` is the 1-based data row (row 1 is the first line after
        the CSV header; ``#`` comment lines and blank lines are not counted).
        When ``file`` is a text file on disk the message ends with the file's
        line number of that row, ``(line N)``; it is also the attribute ``line``.
    """

    def __init__(self, message: str, *, file: str | None = None,
                 column: str | None = None, row: int | None = None):
        self.file, self.column, self.row = file, column, row
        self.line = None if file is None or row is None else data_line(file, row)
        if self.line is not None:
            message = f"{message} (line {self.line})"
        where = []
        if file is not None:
            where.append(f"{file}")
        if column is not None:
            where.append(f"column '{column}'")
        if row is not None:
            where.append(f"row {row}")
        prefix = ", ".join(where)
        super().__init__(printable(f"{prefix}: {message}" if prefix else message))


class ImplausibleValueError(InputError):
    """A value its file's format allows but no real campaign holds: a unit slip (a gate
    rate in Hz under the kHz label, phases in degrees, an amplitude in percent, a
    fraction in place of the shots).  ``dpdfit analyze`` refuses the whole campaign
    for it, where a malformed file only fails the analyses that read it
    (:mod:`dpdfit.recordings.plausibility`)."""


class RefusedFileError(InputError):
    """A file of recordings refused as a whole, before any of its values is looked at: it
    leads out of the folder it was found in, is not a regular file, is larger than the
    bound, or is not a table a lab writes (a NUL byte, a header wider than
    :data:`~dpdfit.core.defaults.MAX_CSV_COLUMNS`, a column named twice, a row wider than
    its header, a cell a spreadsheet would run as a formula).  Such a file is damaged or
    crafted: ``dpdfit analyze`` refuses the whole campaign for it, as for an
    :class:`ImplausibleValueError`, and writes nothing."""


class FitError(DpdfitError):
    """A fit that cannot be done (too few points, singular design, no convergence)."""


class NotInvertibleError(DpdfitError):
    """The fitted amplitude response cannot be inverted on [0, A_corr].

    Attributes
    ----------
    amplitude : float
        The first normalised RF amplitude A at which dy/dA <= 0.
    """

    def __init__(self, message: str, amplitude: float):
        self.amplitude = float(amplitude)
        super().__init__(message)
