"""Synthetic recordings: a physical AOM, the campaign simulator and the injection-recovery harness."""

__all__: list[str] = []
