"""Small least-recently-used caches of the diagnosis's forward models.

The engines keep what a fit evaluates again (a Jacobian's columns share most of their
work): :class:`ModelCache` is a :class:`cachetools.LRUCache` of a few entries, used as a
dict (``cache.get(key)``, ``cache[key] = value``).  A cache of values that every caller
shares (``shared=True``) makes their arrays read-only as they are stored.
"""

from __future__ import annotations

import numpy as np
from cachetools import LRUCache

__all__ = ["CACHE_ENTRIES", "ModelCache"]

#: entries each cache keeps unless it says otherwise
CACHE_ENTRIES = 8


class ModelCache(LRUCache):
    """A least-recently-used cache of at most ``entries`` values; with ``shared``, the
    arrays of a stored value (nested in dicts) are made read-only: every caller shares
    them."""

    def __init__(self, entries: int = CACHE_ENTRIES, shared: bool = False):
        super().__init__(maxsize=entries)
        self.shared = shared

    def __setitem__(self, key, value):
        if self.shared:
            _freeze(value)
        super().__setitem__(key, value)


def _freeze(tree) -> None:
    for v in (tree.values() if isinstance(tree, dict) else (tree,)):
        if isinstance(v, dict):
            _freeze(v)
        elif isinstance(v, np.ndarray):
            v.flags.writeable = False
