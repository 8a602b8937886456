"""Analyses built from fits and models: amplitude sweep, stability, propagation of calibration
drift, error budget and the discrepancy diagnosis."""

__all__: list[str] = []
