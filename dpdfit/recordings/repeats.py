"""Repeated recordings of one setting: legitimate unless their values contradict the noise.

:func:`check_duplicates` judges repeated amplitudes of a calibration run (kept apart
from :mod:`dpdfit.recordings.tables`, which re-exports it); :func:`z_limit` is the
threshold of a 6-sigma rule whose noise scale is estimated from the repeats themselves
(``spectra.csv``, ``gate_rates.csv`` without stated errors).
"""

from __future__ import annotations

import numpy as np
from scipy.stats import norm, t

from dpdfit.errors import InputError

__all__ = ["check_duplicates", "z_limit", "MEDIAN_EFFICIENCY"]

#: statistical efficiency of a median-based scale (the MAD's, 0.37): the degrees of
#: freedom a robust scale estimated from ``nu`` residual degrees of freedom is worth
MEDIAN_EFFICIENCY = 0.37


def z_limit(dof: float, z_max: float = 6.0, efficiency: float = MEDIAN_EFFICIENCY) -> float:
    """Threshold on ``|residual| / s`` with the false-alarm probability of ``z_max``
    standard deviations of a Gaussian, when ``s`` is a scale estimated from ``dof``
    residual degrees of freedom: the Student-t quantile at ``efficiency * dof`` degrees
    of freedom -- for a robust (median-based) scale ``MEDIAN_EFFICIENCY`` (8.0 at 96 dof,
    20 at 27, 6.06 at 2700), for a mean of squares independent of the residual 1; inf
    without any.  A scale estimated from few repeats is itself uncertain, and judging by
    it at 6 would refuse honest data now and then."""
    nu = efficiency * float(dof)
    return float(t.isf(norm.sf(z_max), nu)) if nu > 0 else float("inf")


def check_duplicates(A: np.ndarray, value: np.ndarray, error: np.ndarray | None,
                     rows: np.ndarray, *, file: str, column: str,
                     noise_scale: float | None = None, z_max: float = 6.0) -> None:
    """Refuse repeated amplitudes whose values contradict each other.

    Repeated measurements at the same ``A`` are legitimate and kept.  They
    contradict each other when their spread is inconsistent with the noise:
    the largest deviation from the group's weighted mean exceeds ``z_max``
    standard deviations (``error`` if given, else ``noise_scale``, a robust
    estimate of the per-point scatter supplied by the caller).  ``z_max = 6``
    makes a false alarm on honest Gaussian data practically impossible
    (two-sided p ~ 2e-9 per pair).
    """
    order = np.argsort(A, kind="stable")
    As = A[order]
    same = np.flatnonzero(np.diff(As) == 0)
    if same.size == 0:
        return
    starts = np.unique(np.searchsorted(As, As[same], side="left"))
    for s in starts:
        idx = order[s:np.searchsorted(As, As[s], side="right")]
        v = value[idx]
        if error is not None:
            sig = error[idx]
        elif noise_scale is not None and noise_scale > 0:
            sig = np.full(v.shape, noise_scale)
        else:
            continue  # no noise scale to judge by; the fit's chi-square will tell
        w = 1 / sig**2
        mean = np.sum(w * v) / np.sum(w)
        z = np.abs(v - mean) / sig * np.sqrt(len(v) / max(len(v) - 1, 1))
        if z.max() > z_max:
            r = sorted(int(x) for x in rows[idx])
            raise InputError(
                f"duplicate A={As[s]:g} with contradicting values "
                f"({', '.join(f'{x:.6g}' for x in v)}; {z.max():.1f} sigma apart) in rows "
                f"{', '.join(map(str, r))}", file=file, column=column, row=r[0])
