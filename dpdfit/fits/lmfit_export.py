"""lmfit views of dpdfit's fit results: ``lmfit.Parameters`` and lmfit-style reports.

dpdfit fits with its own least-squares code; :func:`to_parameters` turns a
result (names, values, covariance) into :class:`lmfit.Parameters` with
``value``, ``stderr`` and ``correl`` filled in, so that results can be handed
to code written for lmfit; :func:`lmfit_report` formats a result with
:func:`lmfit.fit_report`.

Error convention: dpdfit's is kept.  The standard errors and correlations are
exactly the fit's -- absolute when the data's sigmas are given, estimated from
the residuals only when they are not (``sigma_source``).  lmfit's default
``scale_covar=True`` rescaling of the covariance by the reduced chi-square is
*not* applied.

lmfit is imported when these functions are called, not by ``import dpdfit``.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

__all__ = ["to_parameters", "lmfit_report", "CONVENTION", "amplitude_parameters",
           "phase_parameters", "alignment_parameters", "amplitude_report", "phase_report",
           "alignment_report"]

#: One line stating the error convention, printed at the top of every report.
CONVENTION = ("errors: dpdfit's convention (absolute with given sigmas, from the residuals "
              "without; no scale_covar rescaling by reduced chi-square)")


def to_parameters(names, values, covariance, *, fixed=(), derived=None):
    """``lmfit.Parameters`` with values, standard errors and correlations of a fit.

    Parameters
    ----------
    names : sequence of str
        Parameter names (valid Python identifiers), in the order of ``values``.
    values : array_like
        Best-fit values.
    covariance : array_like (n, n)
        Their covariance (dpdfit's, not rescaled).
    fixed : iterable of str
        Names held fixed by the model (``vary=False``, no stderr, no correlations).
    derived : dict, optional
        ``name -> (expr, stderr)``: parameters defined by an expression of the
        others (``Parameter.expr``), with their standard error.
    """
    import lmfit       # here: importing lmfit takes ~0.6 s, and only an export needs it
    values = np.asarray(values, dtype=float)
    cov = np.asarray(covariance, dtype=float)
    err = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    fixed = set(fixed)
    free = [i for i, n in enumerate(names) if n not in fixed]
    params = lmfit.Parameters()
    for i, name in enumerate(names):
        params.add(name, value=float(values[i]), vary=name not in fixed)
        par = params[name]
        if name in fixed:
            continue
        par.stderr = float(err[i])
        par.correl = {names[j]: float(cov[i, j] / (err[i] * err[j]))
                      for j in free if j != i and err[i] > 0 and err[j] > 0}
    for name, (expr, stderr) in (derived or {}).items():
        params.add(name, expr=expr)
        params[name].stderr = float(stderr)
    return params


def lmfit_report(params, *, title: str, method: str, ndata: int, chi2: float, dof: int,
                 aic: float, bic: float, nvarys: int | None = None, **kws) -> str:
    """:func:`lmfit.fit_report` of dpdfit's statistics and ``params`` under a title line.

    ``nvarys`` defaults to the number of varying parameters; ``kws`` go to
    :func:`lmfit.fit_report` (``show_correl``, ``min_correl``, ...).
    """
    import lmfit       # here: importing lmfit takes ~0.6 s, and only an export needs it
    if nvarys is None:
        nvarys = sum(1 for p in params.values() if p.vary)
    result = SimpleNamespace(
        params=params, method=method, nfev=None, ndata=int(ndata), nvarys=int(nvarys),
        chisqr=float(chi2), redchi=float(chi2 / dof) if dof > 0 else float("nan"),
        aic=float(aic), bic=float(bic), errorbars=True)
    return f"[[{title}]]  {CONVENTION}\n" + lmfit.fit_report(result, **kws)


def amplitude_parameters(cal, raw: bool = False):
    """:class:`~dpdfit.fits.calibration.AmplitudeCalibration` as ``lmfit.Parameters``.

    Normalised ``a_1`` (fixed at 1 by the normalisation) .. ``a_K`` and
    ``A_corr = a_1 + ... + a_K`` (an expression, with the fit's
    ``A_corr_stderr``); ``raw=True``: the power-domain ``b_1 .. b_K`` (all
    varying, the fit's ``raw_covariance``).
    """
    if raw:
        return to_parameters([f"b_{p}" for p in cal.powers], cal.raw_coefficients,
                             cal.raw_covariance)
    names = [f"a_{p}" for p in cal.powers]
    return to_parameters(names, cal.coefficients, cal.covariance, fixed=names[:1],
                         derived={"A_corr": (" + ".join(names), cal.A_corr_stderr)})


def phase_parameters(cal):
    """:class:`~dpdfit.fits.calibration.PhaseCalibration` as ``lmfit.Parameters``
    ``b_1`` to ``b_K`` (rad)."""
    return to_parameters([f"b_{p}" for p in cal.powers], cal.coefficients, cal.covariance)


def alignment_parameters(fit):
    """:class:`~dpdfit.fits.alignment.AlignmentFit` as ``lmfit.Parameters`` ``alpha_khz``,
    ``delta``."""
    e1, e2 = fit.alpha_khz_err, fit.delta_err
    cov = [[e1 ** 2, fit.correlation * e1 * e2], [fit.correlation * e1 * e2, e2 ** 2]]
    return to_parameters(["alpha_khz", "delta"], [fit.alpha_khz, fit.delta], cov)


def amplitude_report(cal, raw: bool = False, **kws) -> str:
    """lmfit-format report of an amplitude calibration (``kws`` to :func:`lmfit.fit_report`)."""
    return lmfit_report(amplitude_parameters(cal, raw), title="Amplitude calibration",
                        method=f"least_squares (power domain, sigma {cal.sigma_source})",
                        ndata=cal.n_points, chi2=cal.chi2, dof=cal.dof, aic=cal.aic,
                        bic=cal.bic, nvarys=cal.order, **kws)


def phase_report(cal, **kws) -> str:
    """lmfit-format report of a phase calibration (``kws`` to :func:`lmfit.fit_report`)."""
    return lmfit_report(phase_parameters(cal), title="Phase calibration",
                        method=f"linear least squares (sigma {cal.sigma_source})",
                        ndata=cal.n_points, chi2=cal.chi2, dof=cal.dof, aic=cal.aic,
                        bic=cal.bic, **kws)


def alignment_report(fit, **kws) -> str:
    """lmfit-format report of the alignment fit (``kws`` to :func:`lmfit.fit_report`);
    AIC/BIC are not computed by dpdfit for this fit (shown as nan)."""
    return lmfit_report(alignment_parameters(fit), title="Alignment fit",
                        method="least_squares (errors absolute)", ndata=2 * len(fit.points),
                        chi2=fit.chi2, dof=fit.dof, aic=float("nan"), bic=float("nan"), **kws)
