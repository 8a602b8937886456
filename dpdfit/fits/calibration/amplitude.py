"""The AOM amplitude transfer function y(A): fit, order scan and result.

Amplitude (paper, Methods "AOM characterization", Eq. 3)
--------------------------------------------------------
The optical field amplitude is ``y ~ sqrt(power)``.  Rather than taking square
roots of the recorded powers -- which is undefined for the slightly negative
background-subtracted powers near ``A = 0`` and turns the additive detector
noise into a biased, heteroscedastic noise on ``y`` -- dpdfit fits the
recorded power itself, in the units it was measured in:

.. math:: P(A) = \\Big(\\sum_{k=1}^{K} b_k A^k\\Big)^2 ,

by (weighted) least squares, which is the maximum-likelihood estimate under
the photodiode's additive Gaussian noise.  Every point is used, negative ones
included, with its own ``power_err`` (or, without that column, one common
sigma estimated from the residuals).  The normalised coefficients are
``a_k = b_k / b_1`` (unit slope at the origin, ``a_1 = 1``) and
``A_corr = y(1) = sum_k a_k``.  Standard errors of ``a_k`` and ``A_corr``
follow from the full covariance of ``b`` by the delta method (the map b -> a
is smooth and the relative error of ``b_1`` is small).  ``a_1`` is fixed by the
normalisation, so its row and column of the covariance are zero.

Error convention (the same for both fits): with given uncertainties the
covariance is absolute; without them sigma is estimated from the residuals and
the covariance scaled by it.  Never a silent rescale: ``sigma_source`` says which.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from dpdfit.core.adequacy import ModelAdequacy
from dpdfit.core.defaults import AMPLITUDE_ORDER
from dpdfit.core.display import Displayable
from dpdfit.errors import FitError, InputError
from dpdfit.fits.calibration.shared import (frozen_array, gaussian_ic, json_float,
                                            nonmonotone_intervals, run_source, vander)
from dpdfit.fits.lmfit_export import amplitude_parameters, amplitude_report
from dpdfit.fits.polyfit import polyfit
from dpdfit.recordings.calibration_runs import CalibrationData
from dpdfit.recordings.repeats import check_duplicates

__all__ = ["AmplitudeCalibration", "fit_amplitude", "amplitude_order_table",
           "calibrate_amplitude"]


@dataclass(frozen=True, repr=False)
class AmplitudeCalibration(ModelAdequacy, Displayable):
    """Result of the amplitude fit (paper Eq. 3, normalised).

    Attributes
    ----------
    powers : tuple of int
        ``(1, ..., K)``.
    coefficients : ndarray
        Normalised ``a_k`` (``a_1 = 1``): ``y(A) = sum a_k A^k``, dimensionless.
    covariance, stderr : ndarray
        Of ``a_k`` (row/column of ``a_1`` are zero: fixed by normalisation).
    raw_coefficients, raw_covariance : ndarray
        ``b_k`` with ``P(A) = (sum b_k A^k)^2`` in the units of the recorded
        power (``b_1 > 0``) and their covariance.
    A_corr, A_corr_stderr : float
        ``y(1)`` and its 1-sigma standard error.
    power_scale : float
        ``b_1^2``: power per unit ``y^2`` (units of the recorded power).
    monotone : bool
        ``dy/dA >= 0`` on all of [0, 1].
    nonmonotone_intervals : list of (float, float)
        Where ``dy/dA < 0`` on [0, 1].
    chi2, dof, reduced_chi2 : fit statistics in power units (weighted if
        ``sigma_source == "given"``).
    sigma_source : {"given", "residuals"}
    n_points : int
    aic, bic, log_likelihood : Gaussian information criteria.
    source : ``file``, ``sha256``, ``run``, ``timestamp`` when known (dict).
    order_table : AIC/BIC over a range of orders (list of dict, optional).
    """

    _coefficient_symbol = "a"   # the name the guide and the paper give them

    powers: tuple
    coefficients: np.ndarray
    covariance: np.ndarray
    stderr: np.ndarray
    raw_coefficients: np.ndarray
    raw_covariance: np.ndarray
    A_corr: float
    A_corr_stderr: float
    power_scale: float
    monotone: bool
    nonmonotone_intervals: list
    chi2: float
    dof: int
    reduced_chi2: float
    sigma_source: str
    n_points: int
    aic: float
    bic: float
    log_likelihood: float
    source: dict = field(default_factory=dict)
    order_table: list = field(default_factory=list)
    method: str = ("weighted least squares of the recorded power, P(A) = (sum_k b_k A^k)^2, "
                   "all points kept (negative powers included); a_k = b_k/b_1; "
                   "errors by the delta method from the full covariance")
    _adequacy_model = "the model P(A) = (sum_k b_k A^k)^2"

    @property
    def order(self) -> int:
        """The polynomial order K of ``y(A)``, its highest power."""
        return max(self.powers)

    def y(self, A):
        """Normalised optical amplitude y(A) (unit slope at 0)."""
        return vander(A, self.powers) @ self.coefficients

    def dy(self, A):
        """dy/dA."""
        p = np.asarray(self.powers)
        return (vander(A, p - 1) * p) @ self.coefficients

    def y_stderr(self, A):
        """1-sigma confidence band of y(A) from the covariance."""
        V = vander(A, self.powers)
        return np.sqrt(np.maximum(np.einsum("...i,ij,...j->...", V, self.covariance, V), 0))

    def power(self, A):
        """Predicted recorded power (units of the input)."""
        return (vander(A, self.powers) @ self.raw_coefficients) ** 2

    def to_dict(self) -> dict:
        return {
            "powers": list(self.powers),
            "coefficients": self.coefficients.tolist(),
            "stderr": self.stderr.tolist(),
            "covariance": self.covariance.tolist(),
            "monotone": bool(self.monotone),
            "nonmonotone_intervals": [list(iv) for iv in self.nonmonotone_intervals],
            "raw_coefficients": self.raw_coefficients.tolist(),
            "raw_covariance": self.raw_covariance.tolist(),
            "power_scale": self.power_scale,
            "A_corr": self.A_corr,
            "A_corr_stderr": self.A_corr_stderr,
            "chi2": self.chi2, "dof": self.dof, "reduced_chi2": self.reduced_chi2,
            "sigma_source": self.sigma_source, "n_points": self.n_points,
            "aic": self.aic, "bic": self.bic, "log_likelihood": self.log_likelihood,
            "method": self.method, "source": dict(self.source),
            "order_table": list(self.order_table), **self.adequacy_dict(),
            "A_corr_stderr_birge": self.A_corr_stderr_birge,
        }

    @property
    def A_corr_stderr_birge(self) -> float:
        """``A_corr_stderr`` times the Birge factor; ``A_corr_stderr`` stays absolute."""
        return float(self.birge(self.A_corr_stderr))

    def to_frame(self) -> pd.DataFrame:
        """The order scan (:func:`amplitude_order_table`) as a DataFrame, one row per K."""
        return pd.DataFrame(list(self.order_table))

    @classmethod
    def from_dict(cls, d: dict) -> "AmplitudeCalibration":
        """The calibration from its :meth:`to_dict` form (missing keys defaulted; not validated)."""
        return cls(
            powers=tuple(int(p) for p in d["powers"]),
            coefficients=frozen_array(d["coefficients"]),
            covariance=frozen_array(d["covariance"]),
            stderr=frozen_array(d["stderr"]),
            raw_coefficients=frozen_array(d.get("raw_coefficients", d["coefficients"])),
            raw_covariance=frozen_array(d.get("raw_covariance", d["covariance"])),
            A_corr=json_float(d.get("A_corr"), np.sum(d["coefficients"])),
            A_corr_stderr=json_float(d.get("A_corr_stderr"), np.nan),
            power_scale=json_float(d.get("power_scale"), 1.0),
            monotone=bool(d["monotone"]),
            nonmonotone_intervals=[tuple(iv) for iv in d.get("nonmonotone_intervals", [])],
            chi2=json_float(d.get("chi2"), np.nan), dof=int(d.get("dof", 0)),
            reduced_chi2=json_float(d.get("reduced_chi2"), np.nan),
            sigma_source=d.get("sigma_source", "unknown"), n_points=int(d.get("n_points", 0)),
            aic=json_float(d.get("aic"), np.nan), bic=json_float(d.get("bic"), np.nan),
            log_likelihood=json_float(d.get("log_likelihood"), np.nan),
            source=dict(d.get("source", {})), order_table=list(d.get("order_table", [])))

    def report(self) -> str:
        lines = [f"[[Amplitude calibration]]  y(A) = sum_k a_k A^k, K = {self.order}, a_1 = 1",
                 f"    source      : {self.source.get('file', '-')}"
                 + (f"  run {self.source['run']}" if self.source.get("run") else ""),
                 f"    points      : {self.n_points}    dof: {self.dof}",
                 f"    chi2        : {self.chi2:.6g}    reduced chi2: {self.reduced_chi2:.4f}"
                 f"    (sigma {self.sigma_source})",
                 f"    A_corr=y(1) : {self.A_corr:.6f} +/- {self.A_corr_stderr:.6f}",
                 "    monotone    : " + ("yes" if self.monotone else "NO, dy/dA < 0 on "
                                        + ", ".join(f"[{a:.4f}, {b:.4f}]"
                                                    for a, b in self.nonmonotone_intervals)),
                 "    coefficient        value          stderr"]
        for p, c, s in zip(self.powers, self.coefficients, self.stderr):
            lines.append(f"      a_{p:<3d}   {c:+16.9e}  {s:14.6e}"
                         + ("   (fixed by normalisation)" if p == 1 else ""))
        if self.order_table:
            lines.append("    order scan (lower is better; * = minimum):")
            lines.append("       K    chi2          AIC           BIC           A_corr")
            amin = min(r["aic"] for r in self.order_table)
            bmin = min(r["bic"] for r in self.order_table)
            for r in self.order_table:
                lines.append(f"      {r['order']:2d}  {r['chi2']:12.5g}  {r['aic']:12.5g}"
                             f"{'*' if r['aic'] == amin else ' '} {r['bic']:12.5g}"
                             f"{'*' if r['bic'] == bmin else ' '} {r['A_corr']:.6f}")
        lines += self.adequacy_lines({"A_corr": (self.A_corr_stderr, "")})
        return "\n".join(lines)

    def to_lmfit(self, raw: bool = False):
        """The fit as ``lmfit.Parameters``: ``a_1`` (fixed) .. ``a_K`` and ``A_corr``, or
        ``raw=True`` the ``b_k``; ``stderr`` and ``correl`` are dpdfit's (absolute with given
        sigmas; lmfit's ``scale_covar`` rescaling is not applied).  See
        :mod:`dpdfit.fits.lmfit_export`."""
        return amplitude_parameters(self, raw)

    def fit_report(self, raw: bool = False, **kws) -> str:
        """:func:`lmfit.fit_report` of :meth:`to_lmfit` with this fit's statistics."""
        return amplitude_report(self, raw, **kws)


def _amplitude_core(A, power, sigma, order):
    """Fit P = (V b)^2.  Returns (b, cov_b, chi2, n, dof, sigma_source)."""
    powers = tuple(range(1, order + 1))
    n = A.size
    informative = A > 0
    n_distinct = np.unique(A[informative]).size
    if n_distinct < order:
        raise FitError(f"amplitude fit of order K={order} needs at least {order} distinct "
                       f"amplitudes A > 0, got {n_distinct}")
    if sigma is None and n <= order:
        raise FitError(f"amplitude fit of order K={order} without power_err needs more than "
                       f"{order} points to estimate the noise, got {n}")
    w = 1.0 / sigma if sigma is not None else np.ones(n)
    V = vander(A, powers)

    # start: signed square root of the power, an ordinary polynomial fit
    s = np.sign(power) * np.sqrt(np.abs(power))
    b0 = np.asarray(polyfit(A, s, powers, sigma=1.0).coefficients)  # start only
    if b0[0] < 0:
        b0 = -b0

    def resid(b):
        return (power - (V @ b) ** 2) * w

    def jac(b):
        return -2.0 * ((V @ b) * w)[:, None] * V

    sol = least_squares(resid, b0, jac=jac, method="lm", x_scale="jac",
                        xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=2000)
    if not sol.success and sol.status <= 0:
        raise FitError(f"amplitude fit did not converge ({sol.message})")
    b = sol.x if sol.x[0] > 0 else -sol.x
    if not np.all(np.isfinite(b)) or b[0] <= 0:
        raise FitError("fitted slope at the origin is not positive: the data do not look "
                       "like an amplitude calibration (power rising from ~0 at A = 0)")
    # Covariance (and one last Gauss-Newton step) from the linearised problem,
    # which is a weighted polynomial fit: z = (P + y0^2)/(2 y0) with sigma
    # sigma_P/(2|y0|); solved by the ill-conditioning-safe polyfit.
    y0 = V @ b
    use = y0 != 0
    lin = polyfit(A[use], (power[use] + y0[use] ** 2) / (2 * y0[use]), powers,
                  sigma=(1.0 / w[use]) / (2 * np.abs(y0[use])))
    b_new = np.asarray(lin.coefficients)
    if np.sum(resid(b_new) ** 2) <= np.sum(resid(b) ** 2):
        b = b_new
    chi2 = float(np.sum(resid(b) ** 2))
    dof = n - order
    cov = np.array(lin.covariance)
    if sigma is None:
        cov *= chi2 / dof
    return b, cov, chi2, n, dof, ("given" if sigma is not None else "residuals")


def fit_amplitude(A, power, power_err=None, order: int = AMPLITUDE_ORDER, *,
                  source: dict | None = None, order_scan=None) -> AmplitudeCalibration:
    """Fit the AOM amplitude transfer function to recorded photodiode powers.

    Parameters
    ----------
    A : array_like
        Normalised RF amplitudes, 0 <= A <= 1.
    power : array_like
        Background-subtracted integrated photodiode signal, arbitrary units
        (may be negative near A = 0).
    power_err : array_like, optional
        1-sigma of ``power``.  Without it one common sigma is estimated from
        the residuals.
    order : int
        Polynomial order K (paper: 8).
    source : dict, optional
        Provenance (file, sha256, run, timestamp) stored in the result.
    order_scan : iterable of int, optional
        Orders for the AIC/BIC table (e.g. ``range(3, 13)``).

    Returns
    -------
    AmplitudeCalibration
    """
    A = np.asarray(A, dtype=float)
    power = np.asarray(power, dtype=float)
    sigma = None if power_err is None else np.asarray(power_err, dtype=float)
    if A.ndim != 1 or power.shape != A.shape or (sigma is not None and sigma.shape != A.shape):
        raise InputError("A, power and power_err must be 1-D arrays of equal length")
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(power))):
        raise InputError("A and power must be finite")
    if np.any((A < 0) | (A > 1)):
        raise InputError("A must lie in [0, 1]")
    if sigma is not None and not np.all(np.isfinite(sigma) & (sigma > 0)):
        raise InputError("power_err must be finite and > 0")
    if order < 1:
        raise InputError(f"order must be >= 1, got {order}")

    b, cov_b, chi2, n, dof, sigma_source = _amplitude_core(A, power, sigma, order)
    powers = tuple(range(1, order + 1))
    b1 = b[0]
    a = b / b1
    # Jacobian of a = b / b_1 (delta method, full covariance)
    J = np.eye(order) / b1
    J[:, 0] -= b / b1 ** 2
    cov_a = J @ cov_b @ J.T
    cov_a[0, :] = 0.0
    cov_a[:, 0] = 0.0
    A_corr = float(a.sum())
    g = np.full(order, 1.0 / b1)
    g[0] = (1.0 - A_corr) / b1
    A_corr_err = float(np.sqrt(g @ cov_b @ g))
    ll, aic, bic, _ = gaussian_ic(chi2, n, order, sigma)
    intervals = nonmonotone_intervals(a, powers)
    table = []
    if order_scan is not None:
        table = amplitude_order_table(A, power, power_err, order_scan)
    return AmplitudeCalibration(
        powers=powers, coefficients=frozen_array(a), covariance=frozen_array(cov_a),
        stderr=frozen_array(np.sqrt(np.diag(cov_a))), raw_coefficients=frozen_array(b),
        raw_covariance=frozen_array(cov_b), A_corr=A_corr, A_corr_stderr=A_corr_err,
        power_scale=float(b1 ** 2), monotone=not intervals, nonmonotone_intervals=intervals,
        chi2=chi2, dof=dof, reduced_chi2=chi2 / dof if dof > 0 else float("nan"),
        sigma_source=sigma_source, n_points=n, aic=aic, bic=bic, log_likelihood=ll,
        source=dict(source or {}), order_table=table)


def amplitude_order_table(A, power, power_err=None, orders=range(3, 13), *,
                          as_frame: bool = False) -> list[dict] | pd.DataFrame:
    """AIC/BIC of the amplitude fit over a range of orders K.

    Returns one dict per order that could be fitted: ``order``, ``n_params``
    (K, plus one for sigma when estimated), ``chi2``, ``dof``,
    ``log_likelihood``, ``aic``, ``bic``, ``A_corr``, ``A_corr_stderr``.
    All orders use the same data and the same likelihood, so the criteria
    are comparable; the lowest value is preferred.  ``as_frame=True`` returns
    the same rows as a pandas DataFrame.
    """
    A = np.asarray(A, dtype=float)
    power = np.asarray(power, dtype=float)
    sigma = None if power_err is None else np.asarray(power_err, dtype=float)
    out = []
    for K in orders:
        try:
            b, cov_b, chi2, n, dof, _ = _amplitude_core(A, power, sigma, int(K))
        except FitError:
            continue
        ll, aic, bic, k = gaussian_ic(chi2, n, int(K), sigma)
        Ac = float(b.sum() / b[0])
        g = np.full(int(K), 1.0 / b[0])
        g[0] = (1.0 - Ac) / b[0]
        out.append({"order": int(K), "n_params": int(k), "chi2": chi2, "dof": int(dof),
                    "log_likelihood": float(ll), "aic": float(aic), "bic": float(bic),
                    "A_corr": Ac, "A_corr_stderr": float(np.sqrt(g @ cov_b @ g))})
    return pd.DataFrame(out) if as_frame else out


def calibrate_amplitude(data: CalibrationData, order: int = AMPLITUDE_ORDER, order_scan=None
                        ) -> AmplitudeCalibration:
    """Amplitude fit of one validated run, with file-level checks.

    Besides :func:`fit_amplitude` this refuses repeated amplitudes whose
    powers contradict each other (see :func:`dpdfit.recordings.repeats.check_duplicates`)
    and names the file and rows.
    """
    noise = None
    if data.error is None and np.unique(data.A).size < data.A.size:
        # robust per-point scatter from a preliminary fit, to judge duplicates
        try:
            pre = fit_amplitude(data.A, data.value, None, order)
            r = data.value - pre.power(data.A)
            noise = 1.4826 * np.median(np.abs(r - np.median(r)))
        except FitError:
            noise = None
    check_duplicates(data.A, data.value, data.error, data.rows, file=data.source,
                     column="power", noise_scale=noise)
    try:
        return fit_amplitude(data.A, data.value, data.error, order, source=run_source(data),
                             order_scan=order_scan)
    except FitError as exc:
        raise FitError(f"{data.source}: {exc}") from None
