"""A smooth generic discrepancy fitted where the model fails: what an experimenter needs
to go looking for physics that is not in the catalog.

When nothing in the catalog explains the recordings (verdict ``unexplained``),
or the named effects leave an unacceptable fit, each residual series that
deviates -- a located mismatch interval (:func:`~dpdfit.analyses.diagnosis.evidence.mismatches.locate_mismatches`)
or a chi2 significantly above its count, Bonferroni over the series -- gets a
smooth function of its control parameter (amplitude, gate rate, time) fitted in
the model's place: a least-squares cubic spline with ``GENERIC_KNOTS`` interior
knots (a polynomial of degree <= 2 for short series).  The report says, per
series, how much of its chi2 the generic term removes with how many degrees of
freedom, and in total how much of the model's excess chi2 (chi2 - dof) sits in
smooth deviations of located series.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import make_lsq_spline
from scipy.stats import chi2 as chi2_dist

from dpdfit.analyses.diagnosis.evidence.mismatches import locate_mismatches
from dpdfit.analyses.diagnosis.evidence.thresholds import ALPHA

__all__ = ["generic_discrepancy", "GENERIC_KNOTS", "smooth_fit"]

#: interior knots of the generic cubic spline of a series
GENERIC_KNOTS = 3


def smooth_fit(x: np.ndarray, z: np.ndarray):
    """Least-squares smooth function of ``x`` through the standardised residuals ``z``:
    ``(fitted values, degrees of freedom used)``."""
    order = np.argsort(x, kind="stable")
    xs, zs = np.asarray(x, float)[order], np.asarray(z, float)[order]
    ux = np.unique(xs)
    out = np.empty_like(zs)
    if ux.size >= GENERIC_KNOTS + 6:
        k = 3
        inner = np.quantile(ux, np.linspace(0, 1, GENERIC_KNOTS + 2)[1:-1])
        t = np.r_[[ux[0]] * (k + 1), inner, [ux[-1]] * (k + 1)]
        try:
            spl = make_lsq_spline(xs, zs, t, k=k)
            out[order] = spl(xs)
            return out, len(t) - k - 1
        except (ValueError, np.linalg.LinAlgError):
            pass
    deg = int(min(2, ux.size - 2))
    if deg < 0:
        return np.zeros_like(zs), 0
    c = np.polyfit(xs, zs, deg)
    out[order] = np.polyval(c, xs)
    return out, deg + 1


def generic_discrepancy(prob, p: dict) -> dict:
    """The generic discrepancy of the model at parameters ``p`` (module doc)."""
    series = prob.series(p)
    located = {(m["observable"], m["sideband"], -1 if m["dpd"] is None else m["dpd"])
               for m in locate_mismatches(prob, p)}
    rows = []
    chi_all, n_all = 0.0, 0
    for name, sb, d, xname, x, z in series:
        ok = np.isfinite(z)
        x, z = np.asarray(x)[ok], np.asarray(z)[ok]
        chi = float(np.sum(z ** 2))
        chi_all += chi
        n_all += z.size
        excessive = chi2_dist.sf(chi, max(z.size, 1)) * len(series) < ALPHA
        if (name, sb, d) not in located and not excessive:
            continue
        fit, dof = smooth_fit(x, z)
        after = float(np.sum((z - fit) ** 2))
        rows.append({"observable": name, "sideband": sb, "dpd": None if d < 0 else int(d),
                     "x": xname, "range": [float(np.min(x)), float(np.max(x))],
                     "n_points": int(z.size), "chi2_before": chi, "chi2_after": after,
                     "dof_used": int(dof), "located": (name, sb, d) in located,
                     "p_after": float(chi2_dist.sf(after, max(z.size - dof, 1)))})
    rows.sort(key=lambda r: r["chi2_after"] - r["chi2_before"])
    removed = float(sum(r["chi2_before"] - r["chi2_after"] for r in rows))
    dof_used = int(sum(r["dof_used"] for r in rows))
    excess = chi_all - n_all
    return {"series": rows, "chi2_removed": removed, "dof_used": dof_used,
            "excess_chi2": float(excess),
            "fraction_of_excess": float(removed / excess) if excess > 0 else None,
            "form": f"cubic spline, {GENERIC_KNOTS} interior knots, per deviating series"}
