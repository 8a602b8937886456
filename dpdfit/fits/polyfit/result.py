"""The result of a polynomial fit: coefficients, covariance, statistics, evaluation, report.

:class:`PolyFitResult` is immutable (read-only arrays); it evaluates the
fitted polynomial (:meth:`~PolyFitResult.predict`, in double-double) and its
confidence band (:meth:`~PolyFitResult.predict_stderr`), and writes the
JSON-ready :meth:`~PolyFitResult.to_dict` and the readable
:meth:`~PolyFitResult.report`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np
import pandas as pd

from dpdfit.core.adequacy import ModelAdequacy
from dpdfit.core.display import Displayable
from dpdfit.fits.polyfit import double_double as _dd
from dpdfit.fits.polyfit.inputs import format_powers
from dpdfit.fits.polyfit.refine import solve_upper

__all__ = ["PolyFitResult"]


def _readonly(a) -> np.ndarray:
    """A read-only float64 copy."""
    arr = np.array(a, dtype=np.float64, copy=True)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False, repr=False)
class PolyFitResult(ModelAdequacy, Displayable):
    """Result of :func:`polyfit` (immutable; all arrays are read-only).

    Attributes
    ----------
    powers : tuple of int
        Powers ``p_j`` of the model ``y = sum_j c_j x**p_j``, ascending.
    coefficients : ndarray, shape (p,)
        ``c_j``, in units of ``y / x**p_j``.
    covariance : ndarray, shape (p, p)
        Covariance of the coefficients.  Absolute ``(A^T W A)^-1`` when sigma
        was given; ``s**2 (A^T A)^-1`` with ``s**2 = RSS/dof`` when it was not
        (see ``sigma_source``).
    stderr : ndarray, shape (p,)
        ``sqrt(diag(covariance))``.
    residual_std : float
        ``sqrt(chi2 / dof)``: the residual standard deviation in units of y
        for an unweighted fit, the dimensionless weighted residual std (ideally
        ~1) when sigma was given.  NaN when ``dof == 0``.
    chi2 : float
        Weighted residual sum of squares ``sum((y - model)**2 / sigma**2)``
        (plain RSS without sigma).
    dof : int
        Degrees of freedom ``n - p`` (may be 0 when sigma was given).
    reduced_chi2 : float
        ``chi2 / dof`` (NaN when ``dof == 0``).
    r2 : float
        Coefficient of determination ``1 - chi2 / TSS``, with the weighted
        total sum of squares TSS centred on the weighted mean
        ``sum(w y) / sum(w)``, ``w = 1/sigma**2``, when power 0 (a constant)
        is fitted, and *uncentred* (about zero) otherwise, as statsmodels
        does.  NaN when TSS is 0.
    aic, bic : float
        ``-2 lnL + 2 k`` and ``-2 lnL + k ln(n)``, ``k`` as for
        ``log_likelihood``.
    log_likelihood : float
        Gaussian log-likelihood at the fit.  sigma given:
        ``-2 lnL = chi2 + sum(ln(2 pi sigma_i**2))`` and ``k = p``; sigma
        estimated: maximum-likelihood ``sigma_ML**2 = RSS/n``,
        ``-2 lnL = n ln(2 pi RSS/n) + n`` and ``k = p + 1``.
    condition_number : float
        2-norm condition number (ratio of extreme singular values, SVD in
        double) of the weighted design matrix ``x_i**p_j / sigma_i`` in raw
        monomials, as given.  Computed from its triangular factor ``R / scale``
        (same singular values, p x p), which is also the more accurate route
        since QR is invariant to the column scaling.
    condition_number_scaled : float
        The same after the exact power-of-two column equilibration; this is
        what governs the refinement's speed.
    n_points : int
        Number of data points ``n``.
    sigma_source : str
        ``"given"`` or ``"residuals"``.
    refinement_iterations : int
        Number of refinement steps (solves with the double QR, including the
        first one).
    converged : bool
        True when the last refinement correction was below ``REFINE_RTOL``
        (1e-17) of the solution (max-norm, per right-hand side), or the
        corrections stopped shrinking at a level below double resolution
        (2.2e-16).  False (with a RuntimeWarning) when the refinement ended
        with a last correction between that and 1e-6, i.e. with fewer digits
        than double precision but more than ~6; a worse ending raises FitError.

    Notes
    -----
    The private field ``_cov_factor`` (triangular ``T`` with
    ``covariance = T^-1 T^-T``) only serves :meth:`predict_stderr`; it is not
    part of :meth:`to_dict`.
    """

    powers: tuple
    coefficients: np.ndarray
    covariance: np.ndarray
    stderr: np.ndarray
    residual_std: float
    chi2: float
    dof: int
    reduced_chi2: float
    r2: float
    aic: float
    bic: float
    log_likelihood: float
    condition_number: float
    condition_number_scaled: float
    n_points: int
    sigma_source: str
    refinement_iterations: int
    converged: bool
    # Upper-triangular T with covariance = T^-1 T^-T (a scaled R factor of the
    # weighted design); used by predict_stderr to avoid the cancellation in
    # v^T C v with a monomial covariance matrix.
    _cov_factor: np.ndarray = field(default=None, repr=False)
    _adequacy_model = "the polynomial"

    def __post_init__(self):
        set_ = object.__setattr__
        set_(self, "powers", tuple(int(k) for k in self.powers))
        for name in ("coefficients", "covariance", "stderr"):
            set_(self, name, _readonly(getattr(self, name)))
        if self._cov_factor is not None:
            set_(self, "_cov_factor", _readonly(self._cov_factor))
        for name in ("residual_std", "chi2", "reduced_chi2", "r2", "aic", "bic",
                     "log_likelihood", "condition_number", "condition_number_scaled"):
            set_(self, name, float(getattr(self, name)))
        for name in ("dof", "n_points", "refinement_iterations"):
            set_(self, name, int(getattr(self, name)))
        set_(self, "converged", bool(self.converged))
        set_(self, "sigma_source", str(self.sigma_source))

    # -- evaluation ---------------------------------------------------------
    def _full_coefficients(self) -> np.ndarray:
        """Dense coefficients of x**0 .. x**max(powers) (zeros for absent powers)."""
        full = np.zeros(self.powers[-1] + 1)
        full[list(self.powers)] = self.coefficients
        return full

    def predict(self, x):
        """Evaluate the fitted polynomial.

        Horner's scheme on the dense coefficient vector, carried out in
        double-double so that cancellation among large monomial terms (typical
        of ill-conditioned fits) costs no accuracy; the result is the fitted
        double coefficients' polynomial rounded once to double.

        Parameters
        ----------
        x : array_like
            Abscissae (same units as the fitted x).

        Returns
        -------
        ndarray or float
            Model values, same shape as ``x``.
        """
        xa = np.asarray(x, dtype=np.float64)
        full = self._full_coefficients()
        acc = _dd.dd(np.full(xa.shape, full[-1]))
        for c in full[-2::-1]:
            acc = _dd.dd_add_d(_dd.dd_mul_d(acc, xa), c)
        out = _dd.dd_to_float(acc)
        return float(out) if out.ndim == 0 else out

    def predict_stderr(self, x):
        """Standard error of the fitted mean ``sqrt(v^T C v)``, ``v_j = x**p_j``.

        This is the 1-sigma confidence band of the model curve (not a
        prediction interval for new data), with the fit's ``covariance`` C.
        It is computed as ``||T^-T v||`` with the triangular factor of the
        weighted design (``C = T^-1 T^-T``), avoiding the catastrophic
        cancellation of ``v^T C v`` with a monomial covariance; the relative
        accuracy is ~``condition_number_scaled * 1e-16`` or better.

        Parameters
        ----------
        x : array_like
            Abscissae.

        Returns
        -------
        ndarray or float
            Standard errors, same shape as ``x`` (units of y).
        """
        xa = np.asarray(x, dtype=np.float64)
        flat = xa.reshape(-1)
        V = np.stack([flat ** k for k in self.powers], axis=0)    # p x m
        if self._cov_factor is None:        # zero covariance (exact fit, sigma estimated)
            var = np.einsum("im,ij,jm->m", V, self.covariance, V)
        else:
            z = solve_upper(self._cov_factor, V, transpose=True)
            var = np.sum(z * z, axis=0)
        out = np.sqrt(var).reshape(xa.shape)
        return float(out) if out.ndim == 0 else out

    # -- reporting ----------------------------------------------------------
    def to_dict(self) -> dict:
        """Plain-python (JSON-serialisable) copy of the public fields.

        NaN statistics (e.g. ``reduced_chi2`` when ``dof == 0``) stay float
        NaN, which ``json.dumps`` writes as ``NaN``.
        """
        out = {}
        for f in fields(self):
            if f.name.startswith("_"):
                continue
            value = getattr(self, f.name)
            if isinstance(value, np.ndarray):
                value = value.tolist()
            elif isinstance(value, tuple):
                value = list(value)
            out[f.name] = value
        out.update(self.adequacy_dict())
        out["stderr_birge"] = self.stderr_birge.tolist()
        return out

    def to_frame(self) -> pd.DataFrame:
        """The coefficients: ``power``, ``coefficient``, ``stderr``, ``stderr_birge``."""
        return pd.DataFrame({"power": list(self.powers), "coefficient": self.coefficients,
                             "stderr": self.stderr, "stderr_birge": self.stderr_birge})

    def report(self) -> str:
        """Readable multi-line fit report (coefficients, statistics, numerics)."""
        p = len(self.powers)
        if self.sigma_source == "given":
            convention = "given; covariance is absolute (A^T W A)^-1, not rescaled"
        else:
            convention = ("estimated from residuals; covariance = s^2 (A^T A)^-1, "
                          "s^2 = RSS/dof")
        centred = "centred" if 0 in self.powers else "uncentred, no constant"
        status = "converged" if self.converged else "NOT converged"
        dof_note = "  (no residual degrees of freedom)" if self.dof == 0 else ""
        lines = [
            "[[Polynomial fit]]",
            f"    model              = sum_j c_j * x**p_j, p = {format_powers(self.powers)}",
            f"    # data points      = {self.n_points}",
            f"    # coefficients     = {p}",
            f"    degrees of freedom = {self.dof}{dof_note}",
            f"    sigma              = {convention}",
            f"    chi-square         = {self.chi2:.10g}",
            f"    reduced chi-square = {self.reduced_chi2:.10g}",
            f"    residual std       = {self.residual_std:.10g}",
            f"    R-squared          = {self.r2:.10g} ({centred})",
            f"    log-likelihood     = {self.log_likelihood:.10g}",
            f"    AIC                = {self.aic:.10g}",
            f"    BIC                = {self.bic:.10g}",
            "[[Numerics]]",
            f"    condition number   = {self.condition_number:.3g} (weighted monomial design), "
            f"{self.condition_number_scaled:.3g} after power-of-two column scaling",
            f"    refinement         = {status} after {self.refinement_iterations} "
            "iteration(s) (double-double residuals)",
            "[[Coefficients]]",
        ]
        width = max(len(str(k)) for k in self.powers)
        for k, c, s in zip(self.powers, self.coefficients, self.stderr):
            rel = f"({abs(s / c):.2%})" if c != 0 and np.isfinite(s) else "(n/a)"
            lines.append(f"    c{k:<{width}} x^{k:<{width}} = {c: .12e} +/- {s:.4e} {rel}")
        corr = _correlations(self.covariance)
        strong = [(abs(corr[i, j]), i, j) for i in range(p) for j in range(i + 1, p)
                  if abs(corr[i, j]) > 0.1]
        if strong:
            lines.append("[[Correlations]] (largest 5 with |r| > 0.1)")
            for _, i, j in sorted(strong, reverse=True)[:5]:
                lines.append(f"    C(c{self.powers[i]}, c{self.powers[j]}) = {corr[i, j]:+.6f}")
        lines += self.adequacy_lines({f"c{k}": (s, "") for k, s in zip(self.powers, self.stderr)})
        return "\n".join(lines)


def _correlations(cov: np.ndarray) -> np.ndarray:
    """Correlation matrix of a covariance matrix."""
    d = np.sqrt(np.diag(cov))
    with np.errstate(invalid="ignore", divide="ignore"):
        return cov / np.outer(d, d)

