"""Name patterns: one mapping entry for many channels or datasets, e.g. one per tone.

A column's source name may hold placeholders, ``channel = "P_{sideband}_{n}"``:
each placeholder is a column of the same table, and its value in a row is read
from the name that matched (channel ``P_red_2`` gives ``sideband = "red"`` and
``n = 2``).  A placeholder of a counting column (``n``, ``dpd``, ...) matches a
whole number (of at most 18 digits: an int64 holds every one), any other a run of
characters without a dot; a placeholder appears once in a pattern.  Every name of
the file that matches the pattern contributes its rows.

Where a name could be split in several ways, a text placeholder takes the
shortest text and a number the longest that lets the rest of the name match
(``{a}_{b}`` splits ``x_y_z`` into ``x`` and ``y_z``), as a regular expression
``[^.]+?`` and ``[+-]?\\d+`` would.  The split is found in time linear in the
name's length (:func:`match_name`): a backtracking regular expression took
minutes on a crafted name of a few thousand characters.
"""

from __future__ import annotations

import re

from dpdfit.core.defaults import INTEGER_MAX

__all__ = ["placeholders", "repeated_placeholder", "match_name", "matching_keys", "fill"]

_PLACEHOLDER = re.compile(r"\{(\w+)\}")
#: most digits of a number placeholder: every number this long is an int64
_MAX_DIGITS = len(str(INTEGER_MAX)) - 1


def placeholders(name) -> tuple:
    """The placeholders of a source name, in order (empty for a plain name)."""
    return tuple(dict.fromkeys(_PLACEHOLDER.findall(name))) if isinstance(name, str) else ()


def repeated_placeholder(name) -> str | None:
    """A placeholder that appears more than once in ``name`` (None if none does)."""
    found = _PLACEHOLDER.findall(name) if isinstance(name, str) else []
    return next((k for i, k in enumerate(found) if k in found[:i]), None)


def _split(pattern: str) -> tuple[list, list]:
    """(the literal texts, the placeholders between them): one more text than keys."""
    texts, keys, pos = [], [], 0
    for m in _PLACEHOLDER.finditer(pattern):
        texts.append(pattern[pos:m.start()])
        keys.append(m.group(1))
        pos = m.end()
    texts.append(pattern[pos:])
    return texts, keys


def _run_ends(name: str, inside) -> list:
    """``ends[p]``: where the run of characters ``inside`` accepts that starts at ``p``
    ends (``p`` itself when ``name[p]`` is not one); one pass from the end."""
    ends = [len(name)] * (len(name) + 1)
    for p in range(len(name) - 1, -1, -1):
        ends[p] = ends[p + 1] if inside(name[p]) else p
    return ends


def match_name(pattern: str, name: str, numeric) -> dict | None:
    """The placeholder values (text) that make ``name`` match ``pattern`` in full, or
    None; ``numeric`` names the placeholders that take a whole number.

    Dynamic programming from the end of the name: ``fits[i][e]`` says whether the
    part of the pattern after placeholder ``i`` matches ``name[e:]``; the nearest end
    ``e`` that fits is tabulated (``after``/``before``), so each placeholder's end is
    then chosen in one step, from the start.  Time and memory are linear in the
    name's length for each placeholder.
    """
    texts, keys = _split(pattern)
    n = len(name)
    if not keys:
        return {} if name == pattern else None
    if not (name.startswith(texts[0]) and name.endswith(texts[-1])) \
            or n < sum(map(len, texts)):
        return None
    stop = _run_ends(name, lambda c: c != ".")            # text: no dot
    digits = _run_ends(name, str.isdecimal)               # number: what \d matches
    nearest = [None] * len(keys)

    def end(i: int, p: int):
        """Where placeholder i, starting at p, ends so that the rest fits (or None)."""
        if keys[i] in numeric:
            q = p + 1 if p < n and name[p] in "+-" else p
            e = nearest[i][min(digits[q], q + _MAX_DIGITS)]   # the longest number
            return e if e > q else None
        if p >= n or stop[p] == p:
            return None
        e = nearest[i][p + 1]                               # the shortest text
        return e if e <= stop[p] else None

    for i in range(len(keys) - 1, -1, -1):
        rest = texts[i + 1]
        if i == len(keys) - 1:
            fits = [e == n - len(rest) for e in range(n + 1)]
        else:
            fits = [name.startswith(rest, e) and end(i + 1, e + len(rest)) is not None
                    for e in range(n + 1)]
        nearest[i] = _nearest(fits, forward=keys[i] not in numeric)
    values, p = {}, len(texts[0])
    for i, k in enumerate(keys):
        e = end(i, p)
        if e is None:
            return None
        values[k], p = name[p:e], e + len(texts[i + 1])
    return values


def _nearest(fits: list, forward: bool) -> list:
    """For each position x, the nearest e with ``fits[e]``: the first at or after x
    (``forward``; len(fits) when none), else the last at or before x (-1 when none)."""
    out, last = [0] * len(fits), len(fits) if forward else -1
    order = range(len(fits) - 1, -1, -1) if forward else range(len(fits))
    for x in order:
        if fits[x]:
            last = x
        out[x] = last
    return out


def matching_keys(pattern: str, names, numeric) -> list[dict]:
    """The placeholder values of every name that matches ``pattern``: one dict per
    name, ordered by the values (whole numbers as numbers)."""
    keys = []
    for name in names:
        m = match_name(pattern, str(name), numeric)
        if m is not None:
            keys.append({k: int(v) if k in numeric else v for k, v in m.items()})
    order = placeholders(pattern)
    return sorted(keys, key=lambda k: tuple((0, k[p], "") if isinstance(k[p], int)
                                            else (1, 0, k[p]) for p in order))


def fill(pattern: str, key: dict) -> str:
    """``pattern`` with its placeholders replaced by ``key``'s values."""
    return _PLACEHOLDER.sub(lambda m: str(key[m.group(1)]), pattern)
