"""The AOM phase transfer function phi(A): fit and result.

Phase (Supplement S1, Eq. S1)
-----------------------------
``phi(A) = sum_{k=1}^{K} b_k A^k`` (``phi(0) = 0``), K = 5, a linear weighted
least-squares fit on ``A_min <= A <= A_max`` (default 0.1..1); points outside
the window are excluded *explicitly* and counted in the result.

Error convention (the same for both fits): with given uncertainties the
covariance is absolute; without them sigma is estimated from the residuals and
the covariance scaled by it.  Never a silent rescale: ``sigma_source`` says
which.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dpdfit.core.adequacy import ModelAdequacy
from dpdfit.core.defaults import PHASE_MIN_A, PHASE_ORDER
from dpdfit.core.display import Displayable
from dpdfit.errors import FitError, InputError
from dpdfit.fits.calibration.shared import frozen_array, json_float, run_source, vander
from dpdfit.fits.lmfit_export import phase_parameters, phase_report
from dpdfit.fits.polyfit import polyfit
from dpdfit.recordings.calibration_runs import CalibrationData
from dpdfit.recordings.repeats import check_duplicates

__all__ = ["PhaseCalibration", "fit_phase", "calibrate_phase"]


@dataclass(frozen=True, repr=False)
class PhaseCalibration(ModelAdequacy, Displayable):
    """Result of the phase fit (Supplement S1, Eq. S1).

    Attributes
    ----------
    powers : tuple of int
        ``(1, ..., K)`` (no constant: phi(0) = 0).
    coefficients, covariance, stderr : ndarray
        ``b_k`` in rad and their covariance / standard errors.
    phi_at_1, phi_at_1_stderr : float
        ``phi(1)`` in rad.
    A_min, A_max : float
        Fit window; ``n_points`` used, ``n_excluded`` outside it.
    """

    _coefficient_symbol = "b"   # the name the guide and the paper give them

    powers: tuple
    coefficients: np.ndarray
    covariance: np.ndarray
    stderr: np.ndarray
    phi_at_1: float
    phi_at_1_stderr: float
    A_min: float
    A_max: float
    n_points: int
    n_excluded: int
    chi2: float
    dof: int
    reduced_chi2: float
    residual_std: float
    sigma_source: str
    aic: float
    bic: float
    log_likelihood: float
    condition_number: float
    source: dict = field(default_factory=dict)
    _adequacy_model = "the model phi(A) = sum_k b_k A^k"

    @property
    def order(self) -> int:
        """The polynomial order K of ``phi(A)``, its highest power."""
        return max(self.powers)

    @property
    def phi_at_1_stderr_birge(self) -> float:
        """``phi_at_1_stderr`` times the Birge factor; ``phi_at_1_stderr`` stays absolute."""
        return float(self.birge(self.phi_at_1_stderr))

    def phi(self, A):
        """phi(A), rad."""
        return vander(A, self.powers) @ self.coefficients

    def phi_stderr(self, A):
        """1-sigma confidence band of phi(A), rad."""
        V = vander(A, self.powers)
        return np.sqrt(np.maximum(np.einsum("...i,ij,...j->...", V, self.covariance, V), 0))

    def to_dict(self) -> dict:
        return {
            "powers": list(self.powers), "coefficients": self.coefficients.tolist(),
            "stderr": self.stderr.tolist(), "covariance": self.covariance.tolist(),
            "phi_at_1": self.phi_at_1, "phi_at_1_stderr": self.phi_at_1_stderr,
            "A_min": self.A_min, "A_max": self.A_max, "n_points": self.n_points,
            "n_excluded": self.n_excluded, "chi2": self.chi2, "dof": self.dof,
            "reduced_chi2": self.reduced_chi2, "residual_std": self.residual_std,
            "sigma_source": self.sigma_source, "aic": self.aic, "bic": self.bic,
            "log_likelihood": self.log_likelihood, "condition_number": self.condition_number,
            "source": dict(self.source), **self.adequacy_dict(),
            "phi_at_1_stderr_birge": self.phi_at_1_stderr_birge,
        }

    @classmethod
    def from_dict(cls, d: dict) -> "PhaseCalibration":
        """The calibration from its :meth:`to_dict` form (``calibration.json``'s
        ``phase``); older files' missing keys get defaults; not validated."""
        return cls(
            powers=tuple(int(p) for p in d["powers"]),
            coefficients=frozen_array(d["coefficients"]),
            covariance=frozen_array(d["covariance"]), stderr=frozen_array(d["stderr"]),
            phi_at_1=json_float(d.get("phi_at_1"), np.sum(d["coefficients"])),
            phi_at_1_stderr=json_float(d.get("phi_at_1_stderr"), np.nan),
            A_min=json_float(d.get("A_min"), PHASE_MIN_A), A_max=json_float(d.get("A_max"), 1.0),
            n_points=int(d.get("n_points", 0)), n_excluded=int(d.get("n_excluded", 0)),
            chi2=json_float(d.get("chi2"), np.nan), dof=int(d.get("dof", 0)),
            reduced_chi2=json_float(d.get("reduced_chi2"), np.nan),
            residual_std=json_float(d.get("residual_std"), np.nan),
            sigma_source=d.get("sigma_source", "unknown"), aic=json_float(d.get("aic"), np.nan),
            bic=json_float(d.get("bic"), np.nan),
            log_likelihood=json_float(d.get("log_likelihood"), np.nan),
            condition_number=json_float(d.get("condition_number"), np.nan),
            source=dict(d.get("source", {})))

    def report(self) -> str:
        lines = [f"[[Phase calibration]]  phi(A) = sum_k b_k A^k, K = {self.order}, phi(0) = 0",
                 f"    source      : {self.source.get('file', '-')}"
                 + (f"  run {self.source['run']}" if self.source.get("run") else ""),
                 f"    window      : {self.A_min:g} <= A <= {self.A_max:g}  "
                 f"({self.n_points} points used, {self.n_excluded} outside)",
                 f"    chi2        : {self.chi2:.6g}    reduced chi2: {self.reduced_chi2:.4f}"
                 f"    (sigma {self.sigma_source})",
                 f"    phi(1)      : {self.phi_at_1:.6f} +/- {self.phi_at_1_stderr:.6f} rad",
                 "    coefficient        value          stderr"]
        for p, c, s in zip(self.powers, self.coefficients, self.stderr):
            lines.append(f"      b_{p:<3d}   {c:+16.9e}  {s:14.6e}")
        lines += self.adequacy_lines({"phi(1)": (self.phi_at_1_stderr, "rad")})
        return "\n".join(lines)

    def to_lmfit(self):
        """The fit as ``lmfit.Parameters`` ``b_1 .. b_K`` (rad) with ``stderr`` and ``correl``;
        dpdfit's errors (absolute with given sigmas; lmfit's ``scale_covar`` rescaling is not
        applied).  See :mod:`dpdfit.fits.lmfit_export`."""
        return phase_parameters(self)

    def fit_report(self, **kws) -> str:
        """:func:`lmfit.fit_report` of :meth:`to_lmfit` with this fit's statistics."""
        return phase_report(self, **kws)


def fit_phase(A, phase, phase_err=None, order: int = PHASE_ORDER, *, A_min: float = PHASE_MIN_A,
              A_max: float = 1.0, source: dict | None = None) -> PhaseCalibration:
    """Fit the AOM phase transfer function phi(A) (Supplement S1).

    Parameters
    ----------
    A : array_like
        Normalised RF amplitudes.
    phase : array_like
        Measured phase shift, rad.
    phase_err : array_like, optional
        1-sigma of ``phase``, rad; without it sigma is estimated from the
        residuals.
    order : int
        K (paper: 5); powers 1..K.
    A_min, A_max : float
        Fit window (inclusive); the paper uses 0.1 <= A <= 1 because the
        phase is unreliable at low drive.
    """
    A = np.asarray(A, dtype=float)
    phase = np.asarray(phase, dtype=float)
    err = None if phase_err is None else np.asarray(phase_err, dtype=float)
    if not 0 <= A_min < A_max <= 1:
        raise InputError(f"phase fit window must satisfy 0 <= A_min < A_max <= 1, "
                         f"got [{A_min}, {A_max}]")
    use = (A >= A_min) & (A <= A_max)
    n_use = int(use.sum())
    need = order + (1 if err is None else 0)
    if n_use < need:
        raise FitError(f"phase fit of order K={order} on {A_min:g} <= A <= {A_max:g} needs at "
                       f"least {need} points there, got {n_use}")
    res = polyfit(A[use], phase[use], range(1, order + 1),
                  sigma=None if err is None else err[use])
    cov = np.asarray(res.covariance)
    return PhaseCalibration(
        powers=tuple(res.powers), coefficients=frozen_array(res.coefficients),
        covariance=frozen_array(cov), stderr=frozen_array(res.stderr),
        phi_at_1=float(np.sum(res.coefficients)),
        phi_at_1_stderr=float(res.predict_stderr(1.0)),
        A_min=float(A_min), A_max=float(A_max), n_points=n_use,
        n_excluded=int(A.size - n_use), chi2=float(res.chi2), dof=int(res.dof),
        reduced_chi2=float(res.reduced_chi2), residual_std=float(res.residual_std),
        sigma_source=res.sigma_source, aic=float(res.aic), bic=float(res.bic),
        log_likelihood=float(res.log_likelihood),
        condition_number=float(res.condition_number), source=dict(source or {}))


def calibrate_phase(data: CalibrationData, order: int = PHASE_ORDER, A_min: float = PHASE_MIN_A,
                    A_max: float = 1.0) -> PhaseCalibration:
    """Phase fit of one validated run, with the duplicate check."""
    use = (data.A >= A_min) & (data.A <= A_max)
    noise = None
    if (data.error is None and use.sum() > order + 1
            and np.unique(data.A[use]).size < use.sum()):
        pre = polyfit(data.A[use], data.value[use], range(1, order + 1))
        r = data.value[use] - pre.predict(data.A[use])
        noise = 1.4826 * np.median(np.abs(r - np.median(r)))
    check_duplicates(data.A[use], data.value[use],
                     None if data.error is None else data.error[use], data.rows[use],
                     file=data.source, column="phase_rad", noise_scale=noise)
    try:
        return fit_phase(data.A, data.value, data.error, order, A_min=A_min, A_max=A_max,
                         source=run_source(data))
    except FitError as exc:
        raise FitError(f"{data.source}: {exc}") from None

