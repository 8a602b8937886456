"""The expected separation a further recording brings between two causes, the rival
refitted to it.

For two hypotheses, ``a`` taken as true and ``b`` its rival, the rival's parameters
(its fitted ones of the recording's side, and for the tone side the calibration's
error modes) are refitted to ``a``'s predicted recording together with the
recordings so far (T-optimality, Atkinson & Fedorov 1975; KL-optimality for counts,
Lopez-Fidalgo, Tommasi & Trandafir 2007).  Linearised, with ``d`` the whitened
difference of the predictions on the new recording, ``J`` the rival's whitened
Jacobian there and ``F`` its information from the recordings so far
(:meth:`~dpdfit.analyses.diagnosis.proposal.hypotheses.Hypothesis.covariance`), ``k``
independent repeats separate them by

    ``d_k^T (I + J_k F^-1 J_k^T)^-1 d_k = k d.d - k^2 g^T (F + k J^T J)^-1 g``,
    ``g = J^T d``

(Woodbury: :meth:`Direction.linearised`), or, for an item whose repeats pool with what
is recorded (a gate setting's scans share its rate error), the same with the whitening
of ``k`` pooled repeats (:mod:`~dpdfit.analyses.diagnosis.proposal.pooled_scans`); :meth:`Direction.refit` fits the rival's
parameters by nonlinear least squares instead, the recordings so far entering
through ``F``.  A pair is judged in both directions and over every pair of their
forms in reach (:func:`directions`, :func:`separation`): a recording must separate
every form of one from every form of the other.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from dpdfit.analyses.diagnosis.proposal.hypotheses import Hypothesis
from dpdfit.analyses.diagnosis.proposal.menu import white

__all__ = ["Direction", "AbsorbingModel", "absorbing_model", "directions", "separation",
           "REFIT_NFEV"]

#: evaluations of the exact refit of the rival
REFIT_NFEV = 30


@dataclass(frozen=True)
class AbsorbingModel:
    """What one hypothesis's parameters can absorb of an item's recording: the
    parameters ``keys`` that move it, their Jacobian ``J_raw`` (raw, per unit of each
    parameter) and ``J`` (whitened by the pair's ``W``), their covariance ``C`` from the
    recordings so far and its information ``Cinv`` (semi-definite: clipped at 0)."""

    keys: list
    J: np.ndarray
    J_raw: np.ndarray
    C: np.ndarray
    Cinv: np.ndarray


def absorbing_model(item, h: Hypothesis, W) -> AbsorbingModel | None:
    """The parameters of ``h`` that can absorb a recording of ``item`` whitened by ``W``
    (:class:`AbsorbingModel`); None when none moves it or they have no covariance."""
    absorbing = h.absorbing(item.source)
    C = h.covariance([k for k, _ in absorbing]) if absorbing else None
    if C is None:
        return None
    p0, v0 = h.p, item.vector(h)
    J_raw = np.empty((v0.size, len(absorbing)))
    for j, (k, step) in enumerate(absorbing):
        J_raw[:, j] = (item.vector(h, {**p0, k: p0.get(k, 0.0) + step}) - v0) / step
    J = np.column_stack([white(W, c) for c in J_raw.T])
    keep = np.any(J != 0, axis=0)
    if not keep.any():
        return None
    C = np.asarray(C, dtype=float)[np.ix_(keep, keep)]
    # the information, semi-definite: a many-parameter rival's covariance can have a
    # rounding-negative eigenvalue, whose inverse is no information at all
    lam, V = np.linalg.eigh(np.linalg.pinv(C))
    return AbsorbingModel([k for (k, _), y in zip(absorbing, keep) if y], J[:, keep],
                          J_raw[:, keep], C, (V * np.clip(lam, 0.0, None)) @ V.T)


class Direction:
    """One direction of one pair on one item: ``truth`` is taken as true, ``rival``'s
    parameters absorb what they can (module doc)."""

    def __init__(self, item, truth: Hypothesis, rival: Hypothesis, W, profile: bool):
        self.item, self.truth, self.rival, self.W = item, truth, rival, W
        self.raw = item.vector(truth) - item.vector(rival)
        self.d = white(W, self.raw)
        self.dd = float(self.d @ self.d)
        self.keys, self.Cinv, self.J, self.J_raw = [], None, None, None
        # an item whose repeats pool with what is recorded has a whitening per k
        self.pooled = getattr(item, "pooled", None) is not None
        if not profile or self.dd == 0.0:
            return
        model = absorbing_model(item, rival, W)
        if model is None:
            return
        self.keys, self.J, self.J_raw, self.Cinv = model.keys, model.J, model.J_raw, model.Cinv
        self.g = self.J.T @ self.d
        self.H = self.J.T @ self.J

    def whitening(self, k):
        """The whitening of ``k`` repeats: ``sqrt(k) W``, or the pooled one."""
        return (np.sqrt(float(k)) * np.asarray(self.W, dtype=float) if not self.pooled
                else self.item.whitener(self.truth, self.rival, k))

    def _whitened(self, k):
        """``(d_k, J_k)``: the difference and the rival's Jacobian whitened for ``k``
        repeats (``J_k`` None when nothing is profiled)."""
        if not self.pooled:
            r = np.sqrt(float(k))
            return r * self.d, (None if self.J is None else r * self.J)
        Wk = self.item.whitener(self.truth, self.rival, k)
        d = white(Wk, self.raw)
        J = (None if self.J is None else
             np.column_stack([white(Wk, c) for c in self.J_raw.T]))
        return d, J

    def fixed(self, k) -> float:
        """The separation of ``k`` repeats with the rival's parameters held."""
        if not self.pooled:
            return float(k * self.dd)
        d, _ = self._whitened(k)
        return float(d @ d)

    def linearised(self, k) -> np.ndarray:
        """The profiled separation of ``k`` repeats (array-valued in ``k``)."""
        k = np.atleast_1d(np.asarray(k, dtype=float))
        if self.J is None:
            return np.array([self.fixed(kk) for kk in k])
        out = np.empty(k.size)
        for i, kk in enumerate(k):
            if not self.pooled:
                out[i] = kk * self.dd - kk * kk * float(
                    self.g @ np.linalg.solve(self.Cinv + kk * self.H, self.g))
                continue
            d, J = self._whitened(kk)
            g = J.T @ d
            out[i] = float(d @ d) - float(g @ np.linalg.solve(self.Cinv + J.T @ J, g))
        return np.maximum(out, 0.0)

    def refit(self, k: int) -> float:
        """The separation of ``k`` repeats with the rival refitted exactly to the truth's
        predicted recording, the recordings so far entering through its information."""
        if self.J is None:
            return self.fixed(k)
        # L L^T = F from the eigenvalues: F is only semi-definite, where a Cholesky
        # factorisation fails (it took the whole proposal with it)
        lam, V = np.linalg.eigh(self.Cinv)
        L = V * np.sqrt(np.clip(lam, 0.0, None))
        vt, p0, item, rival = self.item.vector(self.truth), self.rival.p, self.item, self.rival
        d_k, J_k = self._whitened(k)
        Wk = self.whitening(k)

        def fun(x):
            p = {**p0, **{key: p0.get(key, 0.0) + v for key, v in zip(self.keys, x)}}
            return np.concatenate([white(Wk, vt - item.vector(rival, p)), L.T @ x])

        scale = np.sqrt(np.maximum(np.diag(np.linalg.pinv(self.Cinv)), 1e-300))
        # the linear optimum
        x0 = np.linalg.solve(self.Cinv + J_k.T @ J_k, J_k.T @ d_k)
        # the Jacobian at the fit, held: each step costs one prediction (the residuals,
        # and so the optimum, are exact; the Jacobian only guides the steps)
        jac = np.vstack([-J_k, L.T])
        try:
            r = least_squares(fun, x0, jac=lambda x: jac, x_scale=scale,
                              max_nfev=REFIT_NFEV, method="trf")
            f = r.fun
        except (ValueError, np.linalg.LinAlgError):
            f = fun(x0)
        return float(min(f @ f, self.fixed(k)))


def directions(item, groups, profile: bool) -> list:
    """For each rival group (against the verdict's group), every pair of forms in both
    directions: ``[[Direction, ...] per rival group]``."""
    out = []
    for g in groups[1:]:
        dirs = []
        for a in groups[0]:
            for b in g:
                W = item.whitener(a, b)
                dirs += [Direction(item, a, b, W, profile), Direction(item, b, a, W, profile)]
        out.append(dirs)
    return out


def separation(dirs: list, k, how: str = "linearised"):
    """The verdict's separation from its nearest rival: the smallest over the rival
    groups, the pairs of forms and both directions, at ``k`` repeats (``how``:
    ``"linearised"``, ``"fixed"`` or ``"refit"``); ``(value, binding direction)``."""
    best, arg = np.inf, None
    for group in dirs:
        for d in group:
            v = float(d.linearised(k)[0]) if how == "linearised" else (
                d.fixed(k) if how == "fixed" else d.refit(k))
            if v < best:
                best, arg = v, d
    return (0.0 if not np.isfinite(best) else best), arg
