"""The measured heterodyne spectra analysed like the simulated sweep (S5, S6.6).

From the recorded tone powers (``spectra.csv``: ``A, dpd, sideband, n, P_dB,
valid``; a tone recorded several times is the mean of its linear powers, valid
when any reading is, :func:`dpdfit.recordings.spectra.pool_spectra`)
:func:`measured_spectra` computes per amplitude, DPD flag and sideband (red,
blue and their mean)

* the IM ratios ``R10 = P1 - P0`` and ``R23 = P2 - P3`` (dB);
* the estimated Bell fidelity ``F_est`` with the chosen formula and with the
  paper's (only where both gate tones were above the noise floor);
* ``dP_n`` (n = 1, 2): the change of the gate-tone powers with DPD at the same
  amplitude;

and, given the simulated sweep, the time-averaged efficiency ``eta_bar`` of
each amplitude from the sweep's spline (S6.6) and the threshold efficiencies
``eta_th`` at which the measured ``eps_est`` first rises through 1e-2, 1e-3,
1e-4 (log-log interpolation, as :func:`dpdfit.analyses.sweep.thresholds`).
The summary also gives the gain in ``R10`` with DPD for ``0.2 <= A <=
A_corr - 0.05`` (where the n = 0 tone was above the noise floor for both
flags).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from dpdfit.analyses.sweep import efficiency_spline, first_crossing
from dpdfit.core.defaults import FORMULA, NBAR
from dpdfit.errors import InputError
from dpdfit.models.fidelity import estimate
from dpdfit.recordings.spectra import pool_spectra

__all__ = ["measured_spectra"]

_HARMONICS = (0, 1, 2, 3)
_KEY = ["A", "dpd", "sideband"]
_LEVELS = {"1e-2": 1e-2, "1e-3": 1e-3, "1e-4": 1e-4}
#: A_corr assumed for the R10-gain window when there is no simulated sweep
_A_CORR_FALLBACK = 0.56


def _tone_tables(spectra: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Powers and validity flags, one row per (A, dpd, sideband), one column per n; the
    repeated readings of a tone pooled first (:func:`~dpdfit.recordings.spectra.pool_spectra`:
    the mean linear power)."""
    spectra = pool_spectra(spectra)
    P = spectra.pivot_table(index=_KEY, columns="n", values="P_dB").reset_index()
    V = spectra.pivot_table(index=_KEY, columns="n", values="valid", aggfunc="min").reset_index()
    for n in _HARMONICS:
        if n not in P.columns:
            raise InputError(f"no rows with n = {n}", file=spectra.attrs.get("source"),
                             column="n")
    return P, V


def _validity(V: pd.DataFrame) -> dict:
    """``{(A, dpd, sideband): validity flags of the harmonics}`` (one lookup per setting)."""
    return dict(zip(V[_KEY].itertuples(index=False, name=None),
                    V[list(_HARMONICS)].to_numpy()))


def _sideband_tones(valid, A, d, grp, nbar, formula) -> dict:
    """``{sideband: (powers, valid, (F_est, F_est with the paper's formula))}`` of one setting.

    ``valid``: :func:`_validity` of the flags table.
    """
    vals = {}
    for sb in ("red", "blue"):
        g = grp[grp.sideband == sb]
        if len(g) != 1:
            continue
        p = g[list(_HARMONICS)].to_numpy(dtype=float)[0]
        v = valid[(A, d, sb)]
        F = (float(estimate(p, _HARMONICS, nbar=nbar, formula=formula).F_est),
             float(estimate(p, _HARMONICS, nbar=nbar, formula="paper").F_est)
             ) if v[1] and v[2] else (np.nan, np.nan)
        vals[sb] = (p, v, F)
    if len(vals) == 2:
        vals["mean"] = (np.mean([x[0] for x in vals.values()], axis=0),
                        np.min([x[1] for x in vals.values()], axis=0),
                        tuple(np.mean([x[2] for x in vals.values()], axis=0)))
    return vals


def _row(A, d, sb, p, v, F) -> dict:
    return {"A": A, "dpd": d, "sideband": sb, "P0_dB": p[0], "P1_dB": p[1],
            "P2_dB": p[2], "P3_dB": p[3], "R10_dB": p[1] - p[0],
            "R23_dB": p[2] - p[3], "P0_valid": int(v[0]), "P3_valid": int(v[3]),
            "gate_valid": int(v[1] and v[2]), "F_est": F[0], "eps_est": 1 - F[0],
            "F_est_paper": F[1], "eps_est_paper": 1 - F[1]}


def _add_power_changes(m: pd.DataFrame) -> None:
    """``dP1_dB``, ``dP2_dB``: gate-tone power with DPD minus without, at matched A."""
    m["dP1_dB"] = np.nan
    m["dP2_dB"] = np.nan
    for sb in ("red", "blue", "mean"):
        d1 = m[(m.dpd == 1) & (m.sideband == sb)].set_index("A")
        d0 = m[(m.dpd == 0) & (m.sideband == sb)].set_index("A")
        common = d1.index.intersection(d0.index)
        for n in (1, 2):
            diff = d1.loc[common, f"P{n}_dB"] - d0.loc[common, f"P{n}_dB"]
            for flag in (0, 1):
                sel = (m.dpd == flag) & (m.sideband == sb) & m.A.isin(common)
                m.loc[sel, f"dP{n}_dB"] = diff.reindex(m.loc[sel, "A"]).to_numpy()


def _thresholds(m: pd.DataFrame, sweep: pd.DataFrame, formula: str) -> dict:
    """Adds ``eta_bar`` from the sweep's spline; the measured threshold efficiencies."""
    for flag in (0, 1):
        sp = efficiency_spline(sweep, flag)
        sel = m.dpd == flag
        m.loc[sel, "eta_bar"] = sp(m.loc[sel, "A"].to_numpy())
    th = {"eta_corr": sweep.attrs.get("eta_corr"), "formula": formula, "eta_th": {},
          "eta_th_paper_formula": {}}
    for flag, k in ((1, "dpd"), (0, "no_dpd")):
        sub = m[(m.dpd == flag) & (m.sideband == "mean") & (m.gate_valid == 1)]
        for key, col in (("eta_th", "eps_est"), ("eta_th_paper_formula", "eps_est_paper")):
            th[key][k] = {lev: first_crossing(sub["eta_bar"], sub[col], val)
                          for lev, val in _LEVELS.items()}
    return th


def _r10_gain(m: pd.DataFrame, sweep: pd.DataFrame | None) -> tuple[int, dict]:
    """Number of amplitudes with both flags; R10 gain with DPD below A_corr (min, max, mean)."""
    mean = m[m.sideband == "mean"]
    d1, d0 = mean[mean.dpd == 1].set_index("A"), mean[mean.dpd == 0].set_index("A")
    Ac = (sweep.attrs.get("A_corr") if sweep is not None else None) or _A_CORR_FALLBACK
    both = d1.index.intersection(d0.index)
    sel = [a for a in both if 0.2 <= a <= Ac - 0.05 and d1.loc[a, "P0_valid"] and d0.loc[a, "P0_valid"]]
    gain = (d1.loc[sel, "R10_dB"] - d0.loc[sel, "R10_dB"]) if sel else pd.Series(dtype=float)
    return int(len(both)), {"min": float(gain.min()) if len(gain) else None,
                            "max": float(gain.max()) if len(gain) else None,
                            "mean": float(gain.mean()) if len(gain) else None,
                            "A_range": [float(min(sel)), float(max(sel))] if sel else None}


def measured_spectra(spectra: pd.DataFrame, sweep: pd.DataFrame | None = None, *,
                     nbar: float = NBAR, formula: str = FORMULA) -> tuple[pd.DataFrame, dict]:
    """IM ratios, ``F_est``, ``dP_n``, ``eta_bar`` and thresholds of the recorded spectra.

    Parameters
    ----------
    spectra : DataFrame
        ``A, dpd, sideband, n, P_dB, valid`` (the validated ``spectra.csv`` of
        :attr:`dpdfit.recordings.campaign_folder.CampaignFolder.spectra`).
    sweep : DataFrame, optional
        The simulated sweep (:func:`dpdfit.analyses.sweep.run_sweep`) of the
        same calibration: gives ``eta_bar`` and the measured thresholds
        (``NaN`` / ``None`` without it).
    nbar, formula :
        Thermal phonon number and fidelity formula of ``F_est``.

    Returns
    -------
    (DataFrame, dict)
        One row per ``A, dpd, sideband`` (columns as ``spectra_measured.csv``,
        sorted by ``dpd, A, sideband``), and the summary ``{"n_amplitudes",
        "R10_gain_dB_below_A_corr", "thresholds_measured"}``.
    """
    P, V = _tone_tables(spectra)
    rows, valid = [], _validity(V)
    for (A, d), grp in P.groupby(["A", "dpd"]):
        for sb, (p, v, F) in _sideband_tones(valid, A, d, grp, nbar, formula).items():
            rows.append(_row(A, d, sb, p, v, F))
    m = pd.DataFrame(rows)
    _add_power_changes(m)
    m["eta_bar"] = np.nan
    th = _thresholds(m, sweep, formula) if sweep is not None else None
    m = m.sort_values(["dpd", "A", "sideband"], ignore_index=True)
    n_both, gain = _r10_gain(m, sweep)
    return m, {"n_amplitudes": n_both, "R10_gain_dB_below_A_corr": gain,
               "thresholds_measured": th}
