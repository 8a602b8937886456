"""Small least-recently-used caches of the diagnosis's forward models.

The engines keep what a fit evaluates again (a Jacobian's columns share most of their
work) in plain dicts, in the order of use: :func:`lru_get` moves an entry to the end,
:func:`lru_put` drops from the front.  Cached arrays are made read-only
(:func:`read_only`): every caller shares them.
"""

from __future__ import annotations

import numpy as np

__all__ = ["CACHE_ENTRIES", "lru_get", "lru_put", "read_only"]

#: entries each cache keeps unless it says otherwise
CACHE_ENTRIES = 8


def lru_get(cache: dict, key):
    """The entry of ``key`` in a least-recently-used ``cache`` (None when absent)."""
    out = cache.pop(key, None)
    if out is not None:
        cache[key] = out                                  # most recently used last
    return out


def lru_put(cache: dict, key, value, entries: int = CACHE_ENTRIES):
    """Store ``value`` under ``key``, dropping the least recently used entry when full."""
    while len(cache) >= entries:
        cache.pop(next(iter(cache)))
    cache[key] = value
    return value


def read_only(tree) -> None:
    """Mark the arrays of a cached entry read-only (every caller shares them)."""
    for v in (tree.values() if isinstance(tree, dict) else (tree,)):
        if isinstance(v, dict):
            read_only(v)
        elif isinstance(v, np.ndarray):
            v.flags.writeable = False
