"""Shared helpers every layer may use: version, defaults, parallel map, progress."""
