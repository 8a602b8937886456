"""Fits of recordings: stable polynomial least squares, AOM calibration, binomial count and parity
likelihoods, tone extraction from heterodyne traces, the calibration posterior, the alignment fit."""

__all__: list[str] = []
