"""Alignment of photodiode-derived fidelity curves with measured gate data (S6.3-S6.4).

The simulated sweep gives, per DPD flag and as smooth functions of the
normalised amplitude ``A`` (cubic splines over the sweep grid, mean of the
two sidebands):

* ``r_rel(A)``: relative gate rate (Eq. S12),
* ``F_PD(A)``: the spectrum-based fidelity estimate ``F_est``,
* ``eta_bar(A)``: time-averaged diffraction efficiency (S6.6).

For each measured point ``i`` (amplitude ``A_i``, flag ``d_i``, calibrated
``xi0_i +/- s_i`` in kHz, measured fidelity ``F_i +/- e_i``) these are
**evaluated at the point's own amplitude and flag**, and the two shared
parameters -- the scale ``alpha`` (kHz, Eq. S13) and the offset
``delta`` -- minimise the stacked weighted residuals::

    horizontal:  (xi0_i - alpha r_rel(A_i, d_i)) / sqrt(s_i^2 + (alpha r_rel(A_i, d_i) k sigma_dB)^2)
    vertical:    (F_i - F_PD(A_i, d_i) - delta) / e_i,

with ``k = ln(10)/20`` (Eq. S14: ``sigma_xi0/xi0 = k sigma_dB``, the
laser-power fluctuation band).  Standard errors are absolute (the inverse of
``J^T J`` of the weighted residuals, never rescaled); the reduced chi-square
is reported beside them.  Because every point's curve values are taken at
its own ``A``, ``alpha`` is fixed by the horizontal and ``delta`` by the
vertical residuals; their correlation is therefore small and is reported.

``xi0_err_khz`` (the stated error of each calibrated gate rate) is optional, as
it is in ``gate_rates.csv``: without it ``s_i = 0`` and the horizontal weights
are the laser-power band alone; the fit says so (:attr:`AlignmentFit.left_out`,
its report and ``to_dict``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.interpolate import CubicSpline
from scipy.optimize import least_squares

from dpdfit.core.adequacy import ModelAdequacy
from dpdfit.core.defaults import ERROR_MODEL
from dpdfit.core.display import Displayable
from dpdfit.errors import FitError, InputError
from dpdfit.fits.lmfit_export import alignment_parameters, alignment_report

__all__ = ["AlignmentFit", "align", "curves", "xi0_band", "K_DB"]

#: ln(10)/20: relative gate-rate change per dB of optical power (Eq. S14).
K_DB = np.log(10) / 20


def xi0_band(xi0, sigma_db: float = ERROR_MODEL.power_jitter_db):
    """Absolute gate-rate spread ``sigma_xi0 = xi0 ln(10)/20 sigma_dB`` (Eq. S14)."""
    return np.asarray(xi0, dtype=float) * K_DB * sigma_db


def curves(sweep: pd.DataFrame) -> dict:
    """Splines ``A -> (r_rel, F_est, eta_bar)`` per DPD flag from a sweep table."""
    out = {}
    for d in (0, 1):
        sub = sweep[(sweep["dpd"] == d) & (sweep["sideband"] == "mean")].sort_values("A")
        if len(sub) < 4:
            raise InputError(f"sweep table has {len(sub)} amplitudes for dpd={d}; need >= 4",
                             file=sweep.attrs.get("source"))
        A = sub["A"].to_numpy(dtype=float)
        out[d] = {k: CubicSpline(A, sub[k].to_numpy(dtype=float))
                  for k in ("r_rel", "F_est", "eta_bar")}
        out[d]["range"] = (float(A[0]), float(A[-1]))
    return out


@dataclass(frozen=True, repr=False)
class AlignmentFit(ModelAdequacy, Displayable):
    """Result of the two-parameter alignment fit.

    Attributes
    ----------
    alpha_khz, alpha_khz_err : float
        Gate-rate scale (kHz per unit r_rel) and its standard error.
    delta, delta_err : float
        Fidelity offset and its standard error.
    correlation : float
        Correlation coefficient of (alpha, delta).
    chi2, dof, redchi : float, int, float
    sigma_db : float
        Laser-power fluctuation used for the horizontal weights.
    points : pandas.DataFrame
        Per point: inputs, ``r_rel``, ``F_PD``, ``eta_bar``, both residuals.
    left_out : tuple of str
        What the fit went without (e.g. the gate rates' stated errors); empty when
        nothing (then ``to_dict`` has no ``left_out`` key).
    """

    alpha_khz: float
    alpha_khz_err: float
    delta: float
    delta_err: float
    correlation: float
    chi2: float
    dof: int
    redchi: float
    sigma_db: float
    points: pd.DataFrame = field(repr=False)
    left_out: tuple = ()
    _adequacy_model = "the model F = F_est + delta (with xi0 = alpha r_rel)"

    @property
    def chi2_parts(self) -> tuple[float, float]:
        """(horizontal, vertical) parts of ``chi2``: the xi0 and the F residuals."""
        return (float((self.points["resid_h"] ** 2).sum()),
                float((self.points["resid_v"] ** 2).sum()))

    @property
    def alpha_khz_err_birge(self) -> float:
        """``alpha_khz_err`` times the Birge factor sqrt(redchi); ``alpha_khz_err`` stays
        the absolute error."""
        return float(self.birge(self.alpha_khz_err))

    @property
    def delta_err_birge(self) -> float:
        """``delta_err`` times the Birge factor sqrt(redchi); ``delta_err`` stays absolute."""
        return float(self.birge(self.delta_err))

    def to_frame(self) -> pd.DataFrame:
        """The per-point table (inputs, curve values, both residuals), a copy."""
        return self.points.copy()

    def to_dict(self) -> dict:
        return {"alpha_khz": self.alpha_khz, "alpha_khz_err": self.alpha_khz_err,
                "delta": self.delta, "delta_err": self.delta_err,
                "correlation": self.correlation, "redchi": self.redchi, "chi2": self.chi2,
                "dof": self.dof, "sigma_db": self.sigma_db, "n_points": int(len(self.points)),
                **self.adequacy_dict(), "alpha_khz_err_birge": self.alpha_khz_err_birge,
                "delta_err_birge": self.delta_err_birge, "chi2_horizontal": self.chi2_parts[0],
                "chi2_vertical": self.chi2_parts[1],
                **({"left_out": list(self.left_out)} if self.left_out else {})}

    def report(self) -> str:
        return "\n".join([
            "[[Alignment fit]] xi0 = alpha r_rel(A, dpd);  F = F_PD(A, dpd) + delta",
            f"    points      : {len(self.points)}   dof: {self.dof}   sigma_dB: {self.sigma_db:g}",
            f"    alpha       : {self.alpha_khz:.4f} +/- {self.alpha_khz_err:.4f} kHz",
            f"    delta       : {self.delta:+.5f} +/- {self.delta_err:.5f}",
            f"    correlation : {self.correlation:+.3f}",
            f"    chi2        : {self.chi2:.3f}   reduced chi2: {self.redchi:.3f} (errors not rescaled)",
        ] + self.adequacy_lines({"alpha": (self.alpha_khz_err, "kHz"),
                                 "delta": (self.delta_err, "")})
            + ([] if self.model_adequate is not False else [
                f"    chi2 parts  : horizontal (xi0) {self.chi2_parts[0]:.3f}, vertical (F) "
                f"{self.chi2_parts[1]:.3f}, {len(self.points)} points each"])
            + [f"    left out    : {note}" for note in self.left_out])

    def to_lmfit(self):
        """The fit as ``lmfit.Parameters`` ``alpha_khz``, ``delta`` with ``stderr`` and
        ``correl``; dpdfit's absolute errors (lmfit's ``scale_covar`` rescaling by the
        reduced chi-square is not applied).  See :mod:`dpdfit.fits.lmfit_export`."""
        return alignment_parameters(self)

    def fit_report(self, **kws) -> str:
        """:func:`lmfit.fit_report` of :meth:`to_lmfit` with this fit's statistics."""
        return alignment_report(self, **kws)


def _check_errors(g: pd.DataFrame, file) -> None:
    """``xi0_err_khz >= 0`` (when given) and ``F_err > 0`` (InputError naming file, column,
    row)."""
    for col, bad in (("xi0_err_khz", g["xi0_err_khz"] < 0 if "xi0_err_khz" in g else None),
                     ("F_err", g["F_err"] <= 0)):
        if bad is not None and bad.any():
            i = int(np.flatnonzero(bad.to_numpy())[0])
            need = ">= 0" if col == "xi0_err_khz" else "> 0"
            raise InputError(f"uncertainty {g[col].iloc[i]:g} must be {need}",
                             file=file or "gate table", column=col, row=i + 1)


def _gate_points(gate: pd.DataFrame) -> pd.DataFrame:
    """The fit's columns of the gate table (``xi0_err_khz`` when given), checked."""
    need = ["A", "dpd", "xi0_khz", "xi0_err_khz", "F", "F_err"]
    missing = [c for c in need if c not in gate.columns and c != "xi0_err_khz"]
    if missing:
        raise InputError(f"gate table lacks column(s) {missing}")
    g = gate[[c for c in need if c in gate.columns]].astype(float).copy()
    g["dpd"] = g["dpd"].astype(int)
    if len(g) < 2:
        src = gate.attrs.get("source")
        raise FitError(f"{src + ': ' if src else ''}alignment needs at least 2 measured "
                       f"points, got {len(g)}")
    _check_errors(g, gate.attrs.get("source"))
    return g


def _no_horizontal_uncertainty(gate: pd.DataFrame, has_sx: bool):
    """InputError naming the file the gate rates' errors come from (``attrs["rates_source"]``,
    e.g. a campaign's ``gate_rates.csv``, else the gate table's) and column ``xi0_err_khz``;
    ``attrs["sigma_db_name"]`` says where ``sigma_db`` was set."""
    file = gate.attrs.get("rates_source") or gate.attrs.get("source") or "gate table"
    what = "every value is 0" if has_sx else "no such column"
    sigma = gate.attrs.get("sigma_db_name") or "sigma_db"
    raise InputError(f"{what}, and the laser-power fluctuation ({sigma}) is 0: the alignment "
                     f"has no horizontal uncertainty; give the gate rates' stated errors or "
                     f"{sigma} > 0", file=file, column="xi0_err_khz")


def align(gate: pd.DataFrame, sweep: pd.DataFrame,
          sigma_db: float = ERROR_MODEL.power_jitter_db) -> AlignmentFit:
    """Fit ``alpha`` and ``delta`` (see module docstring).

    Parameters
    ----------
    gate : DataFrame
        Columns ``A, dpd, xi0_khz, F, F_err`` and optionally ``xi0_err_khz`` (without it
        the horizontal weights are the laser-power band alone, and the fit's
        ``left_out`` says so).
    sweep : DataFrame
        A sweep table (:func:`dpdfit.analyses.sweep.run_sweep` or ``sweep.csv``).
    sigma_db : float
        Laser-power fluctuation (dB rms); default the lab's ``ERROR_MODEL.power_jitter_db``
        (paper: 0.2, Supplement S6.5).
    """
    g = _gate_points(gate)
    has_sx = "xi0_err_khz" in g.columns
    if not np.isfinite(sigma_db) or sigma_db < 0:
        raise InputError(f"sigma_db must be a finite number >= 0, got {sigma_db}")
    cv = curves(sweep)
    r = np.empty(len(g))
    Fpd = np.empty(len(g))
    eta = np.empty(len(g))
    for d in (0, 1):
        m = (g["dpd"] == d).to_numpy()
        if not m.any():
            continue
        lo, hi = cv[d]["range"]
        A = g.loc[m, "A"].to_numpy()
        out = (A < lo) | (A > hi)
        if np.any(out):
            i = int(np.flatnonzero(m)[np.flatnonzero(out)[0]])
            raise InputError(f"measured amplitude A={A[out][0]:g} is outside the sweep's range "
                             f"[{lo:g}, {hi:g}] for dpd={d}", file=gate.attrs.get("source"),
                             column="A", row=i + 1)
        r[m], Fpd[m], eta[m] = cv[d]["r_rel"](A), cv[d]["F_est"](A), cv[d]["eta_bar"](A)
    xi = g["xi0_khz"].to_numpy()
    sx = g["xi0_err_khz"].to_numpy() if has_sx else np.zeros(len(g))
    F, sF = g["F"].to_numpy(), g["F_err"].to_numpy()
    if np.all(sx == 0) and sigma_db == 0:
        _no_horizontal_uncertainty(gate, has_sx)
    left_out = () if has_sx else (
        "xi0_err_khz (the gate rates' stated errors): not given, the horizontal weights "
        f"are the laser-power band alone (sigma_db = {sigma_db:g} dB)",)

    def resid(p):
        alpha, delta = p
        model = alpha * r
        sh = np.sqrt(sx ** 2 + (model * K_DB * sigma_db) ** 2)
        return np.concatenate([(xi - model) / sh, (F - Fpd - delta) / sF])

    a0 = float(np.sum(xi * r) / np.sum(r * r))
    d0 = float(np.average(F - Fpd, weights=sF ** -2))
    sol = least_squares(resid, [a0, d0], method="lm", xtol=1e-14, ftol=1e-14)
    if not sol.success:
        raise FitError(f"alignment fit did not converge: {sol.message}")
    J = sol.jac
    try:
        cov = np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        raise FitError(f"alignment fit is singular: alpha and delta are not determined "
                       f"(sigma_db = {sigma_db:g} dB)") from None
    err = np.sqrt(np.diag(cov))
    chi2 = float(np.sum(sol.fun ** 2))
    dof = 2 * len(g) - 2
    pts = g.copy()
    pts["r_rel"], pts["F_PD"], pts["eta_bar"] = r, Fpd, eta
    n = len(g)
    pts["resid_h"], pts["resid_v"] = sol.fun[:n], sol.fun[n:]
    return AlignmentFit(alpha_khz=float(sol.x[0]), alpha_khz_err=float(err[0]),
                        delta=float(sol.x[1]), delta_err=float(err[1]),
                        correlation=float(cov[0, 1] / (err[0] * err[1])), chi2=chi2, dof=dof,
                        redchi=chi2 / dof if dof > 0 else float("nan"), sigma_db=float(sigma_db),
                        points=pts, left_out=left_out)
