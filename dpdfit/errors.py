"""Exceptions raised by dpdfit.

Every error a user can trigger with bad input is a :class:`DpdfitError`; its
message is one line that says what is wrong and where (file, column, row).
The command line prints that line and exits with a non-zero status.
"""

from __future__ import annotations

__all__ = ["DpdfitError", "InputError", "FitError", "NotInvertibleError"]


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
        the CSV header, i.e. line 2 of the file).
    """

    def __init__(self, message: str, *, file: str | None = None,
                 column: str | None = None, row: int | None = None):
        self.file, self.column, self.row = file, column, row
        where = []
        if file is not None:
            where.append(f"{file}")
        if column is not None:
            where.append(f"column '{column}'")
        if row is not None:
            where.append(f"row {row}")
        prefix = ", ".join(where)
        super().__init__(f"{prefix}: {message}" if prefix else message)


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
