"""Recordings -> validated tables: CSV readers, the campaign folder, trace files, atomic outputs."""

__all__: list[str] = []
