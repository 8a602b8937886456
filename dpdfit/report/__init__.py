"""Figures and written summaries (matplotlib is imported here only)."""
