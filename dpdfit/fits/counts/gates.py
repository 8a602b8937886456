"""Bell-state fidelity per setting ``(A, dpd)`` from raw counts (Supplement S7.1-S7.4).

:func:`gate_fidelities` pools each setting's population scans, fits its parity
scans jointly, combines the two fidelities (:func:`combined_fidelity`, S7.3)
and tests whether the setting's parity scans share one fringe.
"""

from __future__ import annotations

import logging
import math

import numpy as np
import pandas as pd
from scipy import stats

from dpdfit.errors import FitError, InputError
from dpdfit.recordings.counts import PHASE_GRID_RAD, fringe_points, setting_label
from dpdfit.recordings.tables import table_source

from .parity_fit import ParityFit, fit_parity
from .pooling import merge_parity, pool_populations
from .population import PopulationFidelity, interval_method, population_fidelity

__all__ = ["GATE_COLUMNS", "SCAN_CONSISTENCY_ALPHA", "combined_fidelity", "gate_fidelities"]

#: Columns of :func:`gate_fidelities`, in this order (extras follow).
GATE_COLUMNS = ["A", "dpd", "F_pop", "F_pop_err", "F_par", "F_par_err", "F", "F_err",
                "contrast", "phi0", "n_scans", "shots", "interval_method"]
#: A setting's scans failing the one-fringe likelihood-ratio test at this p get a warning.
SCAN_CONSISTENCY_ALPHA = 1e-3

log = logging.getLogger(__name__)


def combined_fidelity(pop, par) -> tuple[float, float]:
    """Bell fidelity ``F = (F_pop + F_par)/2`` and ``sigma = sqrt(s_pop^2 + s_par^2)/2`` (S7.3).

    Parameters
    ----------
    pop : PopulationFidelity or (F_pop, F_pop_err)
    par : ParityFit or (F_par, F_par_err)

    Returns
    -------
    (F, F_err) : tuple of float
        The two error sources are treated as independent (S7.3).
    """
    if isinstance(pop, PopulationFidelity):
        fp, sp = pop.F_pop, pop.F_pop_err
    else:
        fp, sp = map(float, pop)
    if isinstance(par, ParityFit):
        fa, sa = par.F_par, par.A_err
    else:
        fa, sa = map(float, par)
    return 0.5 * (fp + fa), 0.5 * math.hypot(sp, sa)


def _scan_consistency(parity_df) -> dict:
    """Per setting, ``[(A_scan, A_err_scan, nll_scan, label), ...]`` from fitting each parity
    scan alone.  Scans that cannot be fitted alone (too few phases) are left out."""
    out = {}
    groups = parity_df.assign(_s=parity_df["scan"].astype(str)).groupby(["A", "dpd", "_s"])
    for (A, dpd, label), g in groups:
        try:
            r = fit_parity(g["phase_rad"].to_numpy(), g["n_even"].to_numpy(),
                           g["shots"].to_numpy())
        except (FitError, InputError):
            continue
        out.setdefault((float(A), int(dpd)), []).append((r.A, r.A_err, r.nll, label))
    return out


def _scan_lrt(scan_fits, pooled_nll):
    """Likelihood-ratio test of one fringe (A, phi0) for all of a setting's scans
    against one per scan: ``(LR, dof, p)``; NaN with fewer than two fittable scans.

    Only the scans that could be fitted alone enter both sides (the pooled fit is
    repeated on them when some were left out)."""
    if len(scan_fits) < 2:
        return math.nan, 0, math.nan
    nll_sep = sum(f[2] for f in scan_fits)
    lr = max(2.0 * (pooled_nll - nll_sep), 0.0)
    dof = 2 * (len(scan_fits) - 1)
    return float(lr), dof, float(stats.chi2.sf(lr, dof))


def gate_fidelities(populations_df: pd.DataFrame, parity_df: pd.DataFrame,
                    interval: str = "wilson", grid: float = PHASE_GRID_RAD) -> pd.DataFrame:
    """Bell-state fidelity per setting ``(A, dpd)`` from raw counts (S7.1-S7.4).

    Pools the population scans (:func:`pool_populations`), merges the parity
    scans on the common phase grid (:func:`merge_parity`, for the scan counts),
    fits every recorded phase of the setting's parity scans (:func:`fit_parity`,
    the exact pooled likelihood) and combines (:func:`combined_fidelity`).

    Parameters
    ----------
    populations_df, parity_df : pandas.DataFrame
        As returned by :func:`read_populations` / :func:`read_parity` (or
        any frame with their columns).
    interval : {"wilson", "clopper-pearson"}
        Interval method of the population fidelity.

    Returns
    -------
    pandas.DataFrame
        One row per setting, sorted by dpd then A, columns
        :data:`GATE_COLUMNS` (``A, dpd, F_pop, F_pop_err, F_par, F_par_err,
        F, F_err, contrast, phi0, n_scans, shots, interval_method``) then
        ``F_pop_lo, F_pop_hi, F_par_lo, F_par_hi, parity_method,
        parity_flag, A_err_fisher, phi0_err, parity_shots, n_phases,
        n_scans_pop, n_scans_par, parity_converged, parity_scan_chi2,
        parity_scan_dof, parity_scan_p, parity_scan_lr, parity_scan_lr_dof,
        parity_scan_lr_p``.  ``shots`` is the pooled
        population shots; ``n_scans`` the number of distinct scan labels of
        the setting in either table.

    Notes
    -----
    Count-level pooling (S7.4) assumes every scan measures the same fringe.
    ``parity_scan_chi2 = sum_s (A_s - A)^2 / A_err_s^2`` over the scans
    fitted alone (``dof`` = scans - 1, ``parity_scan_p`` its chi-square
    p-value; NaN with a single scan) tests that: a small p means the
    contrast varies between scans (drift) by more than shot noise, and the
    pooled ``F_par_err`` (shot noise only) then understates the error of the
    setting's mean contrast.  It is reported, not applied.
    ``parity_scan_lr`` (``_dof``, ``_p``) is the likelihood ratio of one
    fringe ``(A, phi0)`` for all the scans against one per scan; a p-value
    below :data:`SCAN_CONSISTENCY_ALPHA` is logged as a warning.

    Raises
    ------
    InputError
        A setting present in one table but not the other, bad columns, fewer
        than 3 distinct phases in a setting.
    """
    method = interval_method(interval)
    pop = pool_populations(populations_df)
    par = merge_parity(parity_df, grid=grid)
    _check_same_settings(pop, par, populations_df, parity_df)
    pop_scans, par_scans = _scan_labels(populations_df), _scan_labels(parity_df)
    per_scan = _scan_consistency(parity_df) if "scan" in parity_df.columns else {}
    par_groups = {(float(a), int(d)): g for (a, d), g in par.groupby(["A", "dpd"])}
    raw_groups = _raw_parity(parity_df)
    rows = []
    for rec in pop.itertuples(index=False):
        key = (float(rec.A), int(rec.dpd))
        pf = population_fidelity(rec.n_even, rec.shots, interval=method)
        r = raw_groups[key]
        fit = _fit_setting(key, r, grid, parity_df)
        tests = _scan_tests(key, fit, r, per_scan.get(key, []), parity_df)
        rows.append(_gate_row(key, rec, method, pf, fit, tests, pop_scans.get(key, set()),
                              par_scans.get(key, set()), par_groups[key]))
    out = pd.DataFrame(rows)
    return out.sort_values(["dpd", "A"], kind="stable").reset_index(drop=True)


def _check_same_settings(pop, par, populations_df, parity_df):
    """Every setting needs both populations and parity scans (a Bell fidelity needs both)."""
    pop_keys = {(float(a), int(d)) for a, d in zip(pop["A"], pop["dpd"])}
    par_keys = {(float(a), int(d)) for a, d in zip(par["A"], par["dpd"])}
    missing = sorted(pop_keys - par_keys)
    if missing:
        raise InputError(f"setting {setting_label(*missing[0])} has populations but no parity "
                         "scans (a Bell fidelity needs both)", file=table_source(parity_df))
    missing = sorted(par_keys - pop_keys)
    if missing:
        raise InputError(f"setting {setting_label(*missing[0])} has parity scans but no "
                         "populations (a Bell fidelity needs both)",
                         file=table_source(populations_df))


def _scan_labels(df) -> dict:
    """Per setting, the set of its scan labels in ``df`` ({} without a ``scan`` column)."""
    if "scan" not in df.columns:
        return {}
    g = df.assign(_s=df["scan"].astype(str)).groupby(["A", "dpd"])["_s"]
    return {(float(a), int(d)): set(v) for (a, d), v in g}


def _raw_parity(parity_df) -> dict:
    """Per setting, every recorded phase of every scan (``phase_rad, n_even, shots``, ``_s``).

    The fit uses these (the exact likelihood), not the merged grid: scans whose
    phases jitter around a common set are pooled exactly.
    """
    raw = pd.DataFrame({"A": parity_df["A"].to_numpy(dtype=float),
                        "dpd": parity_df["dpd"].to_numpy().astype(np.int64),
                        "phase_rad": parity_df["phase_rad"].to_numpy(dtype=float),
                        "n_even": parity_df["n_even"].to_numpy(dtype=float),
                        "shots": parity_df["shots"].to_numpy(dtype=float),
                        "_s": (parity_df["scan"].astype(str).to_numpy()
                               if "scan" in parity_df.columns else "1")})
    return {(float(a), int(d)): g for (a, d), g in raw.groupby(["A", "dpd"])}


def _fit_setting(key, r, grid, parity_df) -> ParityFit:
    """The fringe fit of one setting over all its scans' recorded phases ``r``."""
    if fringe_points(r["phase_rad"].to_numpy(), tol=grid / 2) < 3:
        raise InputError(f"setting {setting_label(*key)} has fewer than 3 distinct "
                         "analysis phases (modulo pi); a fringe fit needs at least 3",
                         file=table_source(parity_df), column="phase_rad")
    try:
        return fit_parity(r["phase_rad"].to_numpy(), r["n_even"].to_numpy(),
                          r["shots"].to_numpy())
    except FitError as exc:
        raise FitError(f"setting {setting_label(*key)}: {exc}") from None


def _scan_tests(key, fit, r, scan_A, parity_df):
    """Do the setting's scans share one fringe?  ``(chi2, dof, p, lr, lr_dof, lr_p)``.

    ``scan_A`` are the scans fitted alone (:func:`_scan_consistency`): the
    chi-square of their contrasts about the pooled one, and the likelihood
    ratio (:func:`_scan_lrt`, logged as a warning when it fails).
    """
    if len(scan_A) >= 2:
        chi2 = float(sum((f[0] - fit.A) ** 2 / f[1] ** 2 for f in scan_A))
        dof = len(scan_A) - 1
        p_scan = float(stats.chi2.sf(chi2, dof))
    else:
        chi2, dof, p_scan = math.nan, 0, math.nan
    pooled_nll = fit.nll
    fitted_alone = len(scan_A)
    if 2 <= fitted_alone < r["_s"].nunique():
        # some scans could not be fitted alone: pool only the others for the test
        keep = r[r["_s"].isin([f[3] for f in scan_A])]
        pooled_nll = fit_parity(keep["phase_rad"].to_numpy(), keep["n_even"].to_numpy(),
                                keep["shots"].to_numpy()).nll
    lr, lr_dof, lr_p = _scan_lrt(scan_A, pooled_nll)
    if lr_p < SCAN_CONSISTENCY_ALPHA:
        src = table_source(parity_df)
        log.warning("%ssetting %s: its %d parity scans do not share one fringe "
                    "(likelihood ratio %.1f for %d dof, p = %.2g): pooled F_par_err "
                    "understates the scatter", f"{src}: " if src else "",
                    setting_label(*key), fitted_alone, lr, lr_dof, lr_p)
    return chi2, dof, p_scan, lr, lr_dof, lr_p


def _gate_row(key, rec, method, pf, fit, tests, sp, sq, merged) -> dict:
    """One row of the gate table: pooled populations ``rec`` (fidelity ``pf``), parity fit,
    scan tests, scan labels ``sp`` / ``sq`` of the two tables, merged parity points."""
    F, F_err = combined_fidelity(pf, fit)
    chi2, dof, p_scan, lr, lr_dof, lr_p = tests
    return {
        "A": key[0], "dpd": key[1], "F_pop": pf.F_pop, "F_pop_err": pf.F_pop_err,
        "F_par": fit.F_par, "F_par_err": fit.A_err, "F": F, "F_err": F_err,
        "contrast": fit.A, "phi0": fit.phi0,
        "n_scans": len(sp | sq) if (sp or sq) else int(rec.n_scans),
        "shots": int(rec.shots), "interval_method": method,
        "F_pop_lo": pf.lo, "F_pop_hi": pf.hi, "F_par_lo": fit.A_lo, "F_par_hi": fit.A_hi,
        "parity_method": fit.method, "parity_flag": fit.flag,
        "A_err_fisher": fit.A_err_fisher, "phi0_err": fit.phi0_err,
        "parity_shots": fit.shots_total, "n_phases": fit.n_points,
        "n_scans_pop": len(sp) if sp else int(rec.n_scans),
        "n_scans_par": len(sq) if sq else int(merged["n_scans"].max()),
        "parity_converged": fit.converged,
        "parity_scan_chi2": chi2, "parity_scan_dof": dof, "parity_scan_p": p_scan,
        "parity_scan_lr": lr, "parity_scan_lr_dof": lr_dof, "parity_scan_lr_p": lr_p,
    }
