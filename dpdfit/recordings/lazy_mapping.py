"""A read-only mapping whose values are built on first access.

A results file's datasets, its ndscan scans and a scan's channels are such
mappings (:mod:`.artiq`, :mod:`.ndscan_roots`): their keys are known from the
file's listing, and a value is read only when it is asked for.
"""

from __future__ import annotations

from collections.abc import Mapping

__all__ = ["LazyMapping"]


class LazyMapping(Mapping):
    """A read-only mapping whose value for a key is built on first access, then kept.

    Parameters
    ----------
    keys : iterable
        The keys, in order (known without building any value).
    build : callable
        ``build(key)`` gives the value of ``key``; it may raise
        :class:`~dpdfit.errors.InputError`.
    """

    def __init__(self, keys, build):
        self._keys = dict.fromkeys(keys)
        self._build = build
        self._built = {}

    def __getitem__(self, key):
        if key not in self._keys:
            raise KeyError(key)
        if key not in self._built:
            self._built[key] = self._build(key)
        return self._built[key]

    def __contains__(self, key) -> bool:
        return key in self._keys              # Mapping's would build the value

    def __iter__(self):
        return iter(self._keys)

    def __len__(self) -> int:
        return len(self._keys)

    def __repr__(self) -> str:
        return f"<LazyMapping of {len(self._keys)} keys, {len(self._built)} read>"
