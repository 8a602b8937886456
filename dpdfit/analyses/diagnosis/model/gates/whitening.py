"""The gate observables of one setting decorrelated: they share its random power errors
(the per-scan laser jitter and the rate calibration's error), so their residuals are
whitened by the Cholesky factor of their covariance (:func:`whiten_settings`) and their
chi2 counts the shared error once."""

from __future__ import annotations

import numpy as np

__all__ = ["whiten_prediction", "whiten_stacked", "whiten_settings"]


def whiten_prediction(measured: dict, shot: dict, pr: dict, observables: tuple,
                      logdet: bool = False):
    """Whitened residuals ``(n settings, len(observables))`` of the recorded gate
    observables ``measured`` (shot-noise errors ``shot``) against the gate model's
    prediction ``pr``
    (:meth:`~dpdfit.analyses.diagnosis.model.gates.gate_model.GateModel.predict`), by
    :func:`whiten_settings`."""
    qs = observables
    return whiten_stacked(np.stack([measured[q] for q in qs], axis=1),
                          np.stack([shot[q] for q in qs], axis=1), pr, qs, logdet)


def whiten_stacked(measured, shot, pr: dict, observables: tuple, logdet: bool = False):
    """:func:`whiten_prediction` with the recorded values and their shot-noise errors
    already stacked ``(n settings, len(observables))`` (what a fit keeps between its
    evaluations)."""
    qs = observables
    r = measured - np.stack([pr[q] for q in qs], axis=1)
    return whiten_settings(r, shot, np.stack([pr["dlin_" + q] for q in qs], axis=1),
                           np.stack([pr["dquad_" + q] for q in qs], axis=1),
                           pr["v_lin"], pr["v_quad"], logdet=logdet)


def whiten_settings(r, shot, g, h, v_lin, v_quad, logdet: bool = False):
    """Whitened residuals of each setting's gate observables (shape (n, 3)).

    ``r``: residuals, ``shot``: their shot-noise errors, ``g``, ``h``: the
    settings' responses to the shared random power error (linear and
    quadratic parts, :meth:`~dpdfit.analyses.diagnosis.model.gates.gate_model.GateModel.predict`), with
    variances ``v_lin``, ``v_quad`` (arrays over settings).  The covariance of one
    setting is ``diag(shot^2) + v_lin g g^T + v_quad h h^T``; its Cholesky
    factor ``L`` gives ``z = L^-1 r`` (N(0, I) under the model), whose sum of
    squares is the Mahalanobis chi2.  Settings with a missing value keep the
    marginal standardisation.  Hand-written: a batched 3x3 Cholesky solve.
    """
    v_lin = np.broadcast_to(np.asarray(v_lin, float), r.shape[:1])[:, None, None]
    v_quad = np.broadcast_to(np.asarray(v_quad, float), r.shape[:1])[:, None, None]
    # the products of einsum("i,ij,ik->ijk", v, g, g), in its order, by broadcasting
    # (a fit whitens thousands of times; einsum's parsing costs more than the products)
    cov = (v_lin * g[:, :, None] * g[:, None, :] + v_quad * h[:, :, None] * h[:, None, :]
           + (shot ** 2)[:, :, None] * np.eye(r.shape[1]))
    diag = np.einsum("ijj->ij", cov)
    z = r / np.sqrt(diag)
    ok = np.all(np.isfinite(r), axis=1) & np.all(np.isfinite(cov), axis=(1, 2))
    every = bool(ok.all())                   # the usual case: no row to pick
    L = None
    if every:
        L = np.linalg.cholesky(cov)
        z = np.linalg.solve(L, r[..., None])[..., 0]
    elif ok.any():
        L = np.linalg.cholesky(cov[ok])
        z[ok] = np.linalg.solve(L, r[ok][..., None])[..., 0]
    if not logdet:
        return z
    ld = np.where(np.isfinite(r), np.log(diag), 0.0).sum(axis=1)
    if L is not None:
        ld[ok] = 2 * np.log(np.einsum("ijj->ij", L)).sum(axis=1)
    return z, float(ld.sum())
