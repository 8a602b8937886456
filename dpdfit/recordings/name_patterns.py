"""Name patterns: one mapping entry for many channels or datasets, e.g. one per tone.

A column's source name may hold placeholders, ``channel = "P_{sideband}_{n}"``:
each placeholder is a column of the same table, and its value in a row is read
from the name that matched (channel ``P_red_2`` gives ``sideband = "red"`` and
``n = 2``).  A placeholder of a counting column (``n``, ``dpd``, ...) matches a
whole number, any other a run of characters without a dot.  Every name of the
file that matches the pattern contributes its rows.
"""

from __future__ import annotations

import re

__all__ = ["placeholders", "pattern_regex", "matching_keys", "fill"]

_PLACEHOLDER = re.compile(r"\{(\w+)\}")


def placeholders(name) -> tuple:
    """The placeholders of a source name, in order (empty for a plain name)."""
    return tuple(dict.fromkeys(_PLACEHOLDER.findall(name))) if isinstance(name, str) else ()


def pattern_regex(pattern: str, numeric) -> re.Pattern:
    """The regular expression a name must match in full; ``numeric`` names the
    placeholders that take a whole number."""
    out, pos, seen = [], 0, set()
    for m in _PLACEHOLDER.finditer(pattern):
        out.append(re.escape(pattern[pos:m.start()]))
        key = m.group(1)
        body = r"[+-]?\d+" if key in numeric else r"[^.]+?"
        out.append(f"(?P={key})" if key in seen else f"(?P<{key}>{body})")
        seen.add(key)
        pos = m.end()
    out.append(re.escape(pattern[pos:]))
    return re.compile("".join(out))


def matching_keys(pattern: str, names, numeric) -> list[dict]:
    """The placeholder values of every name that matches ``pattern``: one dict per
    name, ordered by the values (whole numbers as numbers)."""
    rx = pattern_regex(pattern, numeric)
    keys = []
    for name in names:
        m = rx.fullmatch(str(name))
        if m:
            keys.append({k: int(v) if k in numeric else v for k, v in m.groupdict().items()})
    order = placeholders(pattern)
    return sorted(keys, key=lambda k: tuple((0, k[p], "") if isinstance(k[p], int)
                                            else (1, 0, k[p]) for p in order))


def fill(pattern: str, key: dict) -> str:
    """``pattern`` with its placeholders replaced by ``key``'s values."""
    return _PLACEHOLDER.sub(lambda m: str(key[m.group(1)]), pattern)
