"""Figures and written summaries (matplotlib is imported here only)."""

__all__: list[str] = []
