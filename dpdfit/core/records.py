"""Typed results that also read as the JSON dict they stand for.

A :class:`Record` is a small frozen dataclass: its attributes are typed and documented,
and :meth:`Record.to_dict` is its JSON.  Reading it by a JSON key (``record["key"]``,
``record.get("key")``, ``"key" in record``) reads that dict, so a lab's script or
notebook written for the plain dicts these results were before keeps working.
"""

from __future__ import annotations

from dataclasses import fields

__all__ = ["Record"]


class Record:
    """Mixin of a frozen dataclass result, read by attribute or by its JSON keys."""

    def to_dict(self) -> dict:
        """The JSON: every field by its name (override where the JSON differs)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def __getitem__(self, key: str):
        return self.to_dict()[key]

    def __contains__(self, key) -> bool:
        return key in self.to_dict()

    def get(self, key: str, default=None):
        """The JSON's value at ``key``, else ``default`` (as :meth:`dict.get`)."""
        return self.to_dict().get(key, default)

    def keys(self):
        """The JSON's keys."""
        return self.to_dict().keys()
