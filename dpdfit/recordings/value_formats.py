"""The ``format`` of a mapping column: a value written into a label, ``"R{:03d}"``.

A column's ``format`` is applied with :meth:`str.format` to each value (the run 7
becomes ``R007``).  It is checked when the mapping is read, and may hold only what
a label needs: literal text around one replacement field, ``{}`` or ``{:spec}``
(``{0}``, ``{0:spec}``), whose spec is Python's standard format specification
(fill and align, sign, ``z``, ``#``, ``0``, width, grouping, precision, and a type of
``b d e E f F g G n o s x X %``), with a width and a precision of at most
:data:`~dpdfit.core.defaults.FORMAT_MAX_WIDTH`.  Refused: the value's attributes
or items (``{0.real}``, ``{0[1]}``), conversions (``{!r}``), fields inside the
spec (``{:{}}``), the type ``c`` (a character, not a number) and control
characters, so that a format can neither reach into the value's objects nor ask for
gigabytes of padding.
"""

from __future__ import annotations

import re
from string import Formatter

from dpdfit.core.defaults import FORMAT_MAX_CHARS, FORMAT_MAX_WIDTH

__all__ = ["FormatError", "check_format"]

# Python's standard format specification ("Format Specification Mini-Language"):
# [[fill]align][sign]["z"]["#"]["0"][width][grouping]["." precision][type]
_SPEC = re.compile(r"(?:.?[<>=^])?[-+ ]?z?#?0?(?P<width>[0-9]*)[,_]?"
                   r"(?:\.(?P<precision>[0-9]+))?[bdeEfFgGnosxX%]?", re.DOTALL)


class FormatError(ValueError):
    """A ``format`` outside what :func:`check_format` allows; the message says why."""


def check_format(text) -> str:
    """``text`` if it is a ``format`` a column may have (module doc), else FormatError."""
    if not isinstance(text, str):
        raise FormatError(f"must be a string such as \"R{{:03d}}\", got {type(text).__name__}")
    if len(text) > FORMAT_MAX_CHARS:
        raise FormatError(f"is {len(text)} characters long (at most {FORMAT_MAX_CHARS})")
    if not text.isprintable():
        raise FormatError("holds a control character (a label is one line of text)")
    try:
        parts = list(Formatter().parse(text))
    except ValueError as exc:
        raise FormatError(f"'{text}' is not a str.format text ({exc})") from None
    fields = [(name, spec, conv) for _, name, spec, conv in parts if name is not None]
    if len(fields) != 1:
        raise FormatError(f"'{text}' has {len(fields)} replacement fields; a format has "
                          "one, {} or {:spec}, for the value")
    name, spec, conv = fields[0]
    if name not in ("", "0"):
        raise FormatError(f"'{text}': the field '{{{name}}}' names something other than "
                          "the value; write {} or {:spec}")
    if conv is not None:
        raise FormatError(f"'{text}': a conversion (!{conv}) is not allowed; write {{:spec}}")
    m = _SPEC.fullmatch(spec)
    if "{" in spec or m is None:
        raise FormatError(f"'{text}': '{spec}' is not a standard format spec "
                          "([[fill]align][sign][#][0][width][,][.precision][type], a "
                          "type of b d e E f F g G n o s x X %)")
    for part in ("width", "precision"):
        if m.group(part) and int(m.group(part)) > FORMAT_MAX_WIDTH:
            raise FormatError(f"'{text}' asks for a {part} of {int(m.group(part))} "
                              f"(at most {FORMAT_MAX_WIDTH})")
    return text
