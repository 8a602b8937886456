"""Shared helpers every layer may use: version, defaults, parallel map, progress."""

__all__: list[str] = []
