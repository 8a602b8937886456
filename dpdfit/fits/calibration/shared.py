"""Helpers shared by the amplitude and phase calibration fits and their results.

Read-only arrays, JSON number reading, the monomial design, the Gaussian
information criteria of a fit, the provenance of a recorded run, and the
intervals where a fitted polynomial decreases.
"""

from __future__ import annotations


import numpy as np

from dpdfit.recordings.outputs import file_sha256
from dpdfit.recordings.calibration_runs import CalibrationData

__all__ = ["frozen_array", "json_float", "vander", "gaussian_ic", "run_source",
           "nonmonotone_intervals", "run_record", "RUN_RECORD_KEYS"]


def frozen_array(a) -> np.ndarray:
    """A read-only float copy of ``a``."""
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


def json_float(value, default=float("nan")) -> float:
    """float(value), with JSON null (None) read as ``default``."""
    return float(default) if value is None else float(value)


def vander(A, powers) -> np.ndarray:
    """Monomials ``A**p`` for each power, along a new last axis."""
    return np.asarray(A, dtype=float)[..., None] ** np.asarray(powers)


def gaussian_ic(chi2: float, n: int, n_coef: int, sigma: np.ndarray | None):
    """(log_likelihood, aic, bic, k) under the stated sigma convention."""
    if sigma is not None:
        m2ll = chi2 + float(np.sum(np.log(2 * np.pi * sigma ** 2)))
        k = n_coef
    else:
        m2ll = n * np.log(2 * np.pi * chi2 / n) + n
        k = n_coef + 1
    return -0.5 * m2ll, m2ll + 2 * k, m2ll + k * np.log(n), k


#: the keys of a fit's ``to_dict`` in one run's record (``dpdfit calibrate --all-runs``)
RUN_RECORD_KEYS = {
    "amplitude": ("A_corr", "A_corr_stderr", "monotone", "reduced_chi2", "coefficients",
                  "stderr", "raw_coefficients", "raw_covariance", "n_points"),
    "phase": ("phi_at_1", "phi_at_1_stderr", "coefficients", "stderr", "covariance",
              "reduced_chi2", "n_points"),
}


def run_record(cal, kind: str) -> dict:
    """One run's record: its label and timestamp, then :data:`RUN_RECORD_KEYS` of the fit's
    ``to_dict`` (the calibration JSON schema is written in ``to_dict`` alone)."""
    d = cal.to_dict()
    return {"run": cal.source.get("run"), "timestamp": cal.source.get("timestamp"),
            **{k: d[k] for k in RUN_RECORD_KEYS[kind]}}


def run_source(data: CalibrationData) -> dict:
    """Provenance of a recorded run: ``file``, ``sha256``, ``run``, ``timestamp``."""
    return {"file": data.source, "sha256": file_sha256(data.source), "run": data.run,
            "timestamp": data.timestamp}


def nonmonotone_intervals(coefficients, powers, lo: float = 0.0, hi: float = 1.0
                          ) -> list[tuple[float, float]]:
    """Intervals of ``[lo, hi]`` on which ``d/dA sum_k c_k A^k < 0``.

    Found exactly from the real roots of the derivative polynomial; touching
    zeros (no sign change) are not intervals.
    """
    powers = np.asarray(powers)
    deg = int(powers.max())
    dcoef = np.zeros(deg)                      # ascending coefficients of y'
    for c, p in zip(coefficients, powers):
        if p > 0:
            dcoef[p - 1] += p * c
    roots = np.polynomial.polynomial.polyroots(dcoef) if deg > 1 else np.array([])
    real = np.sort(roots[np.abs(roots.imag) < 1e-9].real)
    edges = np.concatenate([[lo], real[(real > lo) & (real < hi)], [hi]])
    out: list[tuple[float, float]] = []
    for a, b in zip(edges[:-1], edges[1:]):
        mid = 0.5 * (a + b)
        if np.polynomial.polynomial.polyval(mid, dcoef) < 0:
            if out and abs(out[-1][1] - a) < 1e-12:
                out[-1] = (out[-1][0], float(b))
            else:
                out.append((float(a), float(b)))
    return out

