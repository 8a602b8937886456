"""Where a key of an import mapping is, and the one-line error that names it.

:mod:`tomllib` gives no line numbers, so :class:`KeyLines` finds them in the text:
the line of each ``[[table]]`` entry and of each key in it.  It reads the text once
per table asked about and keeps what it found, so that naming every column of a
mapping of thousands of entries costs time linear in its length (finding each key
by reading the text again made it quadratic: 1,000 entries took 23 s).
:class:`MappingErrors` raises the :class:`~dpdfit.errors.InputError` of a bad
mapping, naming the key and its line; :func:`one_line` keeps a message that shows
the mapping's own text on one line.
"""

from __future__ import annotations

import difflib
import re

from dpdfit.errors import InputError

__all__ = ["KeyLines", "MappingErrors", "one_line"]

# control characters (the line breaks str.splitlines() knows among them) shown escaped
_ESCAPED = {c: repr(chr(c))[1:-1]
            for c in [*range(32), *range(127, 160), 0x2028, 0x2029]}


def one_line(text) -> str:
    """``text`` with its control characters escaped (``\\n`` as a backslash and ``n``):
    a message quoting a mapping's or a results file's text stays one line."""
    return str(text).translate(_ESCAPED)


class KeyLines:
    """Line numbers of a mapping's tables and keys, for messages."""

    def __init__(self, text: str):
        self.text = text.splitlines()
        self._tables = {}

    def find(self, table: str, key: str | None = None, index: int = 0) -> int | None:
        """The line of ``key`` in the ``index``-th ``[[table]]`` entry (or of the entry's
        header; or of ``[table]``/``table = ...``); None when not found."""
        if table not in self._tables:
            self._tables[table] = self._read(table)
        heads, keys, assigned = self._tables[table]
        if key is not None and (index, key) in keys:
            return keys[(index, key)]
        found = [n for n in (heads.get(index), assigned) if n is not None]
        return min(found) if found else None

    def _read(self, table: str):
        """(first line of each entry, {(entry, key): its first line}, first line
        ``table = ...``) of one table, in one pass over the text.  A line belongs to
        entry k after the k-th ``[[table]]`` header and after a ``[table.sub]`` header
        that follows it (entry 0 before any); another header ends the entry."""
        entry = re.compile(r"\s*\[\[\s*" + re.escape(table) + r"\s*\]\]")
        header = re.compile(r"\s*\[\[?\s*" + re.escape(table) + r"(\.[\w.]+)?\s*\]\]?")
        assign = re.compile(r"\s*" + re.escape(table) + r"\s*=")
        heads, keys, assigned = {}, {}, None
        seen, inside = -1, None
        for i, line in enumerate(self.text, 1):
            if entry.match(line):
                seen += 1
                inside = seen
                heads.setdefault(inside, i)
            elif header.match(line):
                inside = max(seen, 0)
                heads.setdefault(inside, i)
            elif line.lstrip().startswith("["):
                inside = None
            elif assigned is None and assign.match(line):
                assigned = i
            if inside is not None and "=" in line:
                keys.setdefault((inside, line.split("=", 1)[0].strip()), i)
        return heads, keys, assigned


class MappingErrors:
    """Raises the InputError of a bad mapping: ``key '...' (line N): what is wrong``."""

    def __init__(self, file: str, lines: KeyLines):
        self.file, self.lines = file, lines

    def _raise(self, key: str, msg: str, table=None, column=None):
        m = re.match(r"^(\w+)(?:\[(\d+)\])?", key or "")
        index = int(m.group(2)) - 1 if m and m.group(2) else 0
        line = self.lines.find(table or (m.group(1) if m else key), column, index)
        where = f"key '{key}'" if key else "mapping"
        where += f" (line {line})" if line else ""
        raise InputError(one_line(f"{where}: {msg}"), file=self.file)

    def bad(self, key, msg, table=None, column=None):
        """Refuse the value of ``key`` (in entry ``key``'s ``[n]`` of ``table``, on the
        line of ``column`` there when given)."""
        self._raise(key, msg, table, column)

    def unknown(self, key, name, known, what, table=None, column=None):
        """Refuse ``name``, which is none of ``known``; the nearest one is suggested."""
        near = difflib.get_close_matches(str(name), [str(k) for k in known], n=1)
        hint = f" (did you mean '{near[0]}'?)" if near else ""
        self._raise(key, f"unknown {what} '{name}'{hint}", table,
                    column if column else (name if table else None))

    def table(self, v, key, table=None):
        """Refuse ``v`` unless it is a table."""
        if not isinstance(v, dict):
            self._raise(key, "must be a table", table)
