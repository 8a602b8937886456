"""The separation a proposed recording achieves, simulated: replicates of the recording.

The expected separation (:mod:`~dpdfit.analyses.diagnosis.proposal.expected_separation`)
is what the recording brings on average, linearised, with the truth's parameters at
their fit.  The separation a lab measures scatters about it: the recording's own noise,
the noise the rival's parameters absorb, and the truth's parameters, known only to
their errors.  Before a recording is called decisive it is therefore simulated
(:func:`replicate_separations`): for one direction of a pair (``truth`` taken as true,
``rival`` its rival) at ``k`` repeats, each of :data:`REPLICATES` replicates

1. draws the truth's parameters that move the recording (its fitted ones of that side,
   and for the tone side the calibration's error modes) from their covariance from the
   recordings so far, ``theta = p_truth + delta``, ``delta ~ N(0, C_truth)``;
2. simulates the recording: the truth's prediction at ``theta`` plus Gaussian noise,
   standard normal in the whitened space of ``k`` repeats (``sqrt(k) W``, or the
   whitening of ``k`` repeats pooled with what is recorded,
   :mod:`~dpdfit.analyses.diagnosis.proposal.pooled_scans`);
3. refits both hypotheses to it, each over its parameters that can absorb the
   recording, the recordings so far entering through their information
   (``x^T F x`` on each one's offset from its fit: for the truth it pulls the drawn
   parameters back towards its fit, as the recordings so far would), by the same
   nonlinear least squares with the Jacobian held as
   :meth:`~dpdfit.analyses.diagnosis.proposal.expected_separation.Direction.refit`, each
   from a start near its optimum (the rival from its refit to the truth's noise-free
   recording, moved linearly by the replicate's deviation from it; the truth from the
   drawn parameters, one Newton step on), in at most :data:`REPLICATE_NFEV` predictions;
4. takes the separation ``chi2_rival - chi2_truth``: the delta chi2 the diagnosis of the
   campaign with the recording would see between the two.

The replicates are seeded from the item, its repeats and the pair
(:data:`REPLICATE_SEED`): a diagnosis is reproducible.  :func:`summary` gives their
median and 10th percentile, what the proposal reports and judges a recording by.
"""

from __future__ import annotations

import json
import zlib

import numpy as np
from scipy.optimize import least_squares

from dpdfit.analyses.diagnosis.proposal.expected_separation import (Direction,
                                                                    absorbing_model)
from dpdfit.analyses.diagnosis.proposal.menu import white

__all__ = ["REPLICATES", "REPLICATE_SEED", "REPLICATE_NFEV", "REPLICATE_FTOL", "PERCENTILE",
           "replicate_separations", "summary"]

#: replicates of a proposed recording under each hypothesis of its binding pair
REPLICATES = 12

#: the fixed part of every replicate's seed (the rest is drawn from the item, its repeats
#: and the pair), so that a diagnosis is reproducible
REPLICATE_SEED = 20250611

#: evaluations of each refit of a replicate (each one prediction).  Fewer than the
#: proposal's :data:`~dpdfit.analyses.diagnosis.proposal.expected_separation.REFIT_NFEV`:
#: each refit starts near its optimum (below), and the refits that do not converge within
#: them are those of a rival far from the recording (separations of thousands on the
#: validation campaigns, a few per cent high), never near the threshold that decides, where
#: the rival fits the recording almost as well as the truth and converges in a few steps
REPLICATE_NFEV = 10

#: relative change of a replicate's chi2 at which its refit stops (1e-4 of a chi2 of a few
#: hundred: hundredths, nothing next to the threshold of 10)
REPLICATE_FTOL = 1e-4

#: the percentile of the replicates' separations that must decide
PERCENTILE = 10.0


class _Refit:
    """One hypothesis refitted to a simulated recording: its parameters that absorb the
    recording of the item, their Jacobian whitened for ``k`` repeats (held) and the
    square root of their information (``L L^T = F``); nothing when none absorbs it."""

    def __init__(self, item, h, W, Wk):
        self.item, self.h = item, h
        self.model = absorbing_model(item, h, W)
        if self.model is None:
            return
        lam, V = np.linalg.eigh(self.model.Cinv)
        self.L = V * np.sqrt(np.clip(lam, 0.0, None))
        self.Jk = np.column_stack([white(Wk, c) for c in self.model.J_raw.T])
        self.jac = np.vstack([-self.Jk, self.L.T])
        self.A = self.model.Cinv + self.Jk.T @ self.Jk
        self.scale = np.sqrt(np.maximum(np.diag(np.linalg.pinv(self.model.Cinv)), 1e-300))

    def params(self, x) -> dict:
        p0 = self.h.p
        return {**p0, **{k: p0.get(k, 0.0) + v for k, v in zip(self.model.keys, x)}}

    def step(self, dev) -> np.ndarray:
        """The linear change of the optimum for a change ``dev`` of the whitened
        residuals: ``(F + J^T J)^-1 J^T dev``."""
        return np.linalg.lstsq(self.A, self.Jk.T @ dev, rcond=None)[0]

    def fit(self, v_obs, noise, Wk, x0=None) -> tuple:
        """``(chi2, x)``: the smallest ``|white(Wk, v_obs - prediction) + noise|^2 +
        x^T F x`` over the hypothesis's offset ``x`` from its fit, from ``x0`` (default:
        the linear optimum from the fit) with the Jacobian held; at the fit when nothing
        absorbs the recording."""
        def fun(x):
            p = self.h.p if self.model is None else self.params(x)
            r = white(Wk, v_obs - self.item.vector(self.h, p)) + noise
            return r if self.model is None else np.concatenate([r, self.L.T @ x])

        # at the fit: its prediction is memoised, no model evaluation
        f0 = fun(None if self.model is None else np.zeros(len(self.model.keys)))
        if self.model is None:
            return float(f0 @ f0), None
        if x0 is None:
            x0 = self.step(f0[:self.Jk.shape[0]])
        try:
            r = least_squares(fun, x0, jac=lambda x: self.jac, x_scale=self.scale,
                              max_nfev=REPLICATE_NFEV, method="trf", ftol=REPLICATE_FTOL)
            f, x = r.fun, r.x
        except (ValueError, np.linalg.LinAlgError):
            f, x = fun(x0), x0
        if f0 @ f0 < f @ f:
            return float(f0 @ f0), np.zeros_like(x)
        return float(f @ f), x


def _seed(direction: Direction, k: int) -> list:
    """The replicates' seed: :data:`REPLICATE_SEED` and a checksum of the item (what,
    settings), its repeats and the pair (``json`` and ``crc32``: the same in every
    process, unlike ``hash``)."""
    item = direction.item
    key = json.dumps([getattr(item, "what", ""), getattr(item, "settings", {}), int(k),
                      getattr(direction.truth, "label", ""),
                      getattr(direction.rival, "label", "")], sort_keys=True, default=str)
    return [REPLICATE_SEED, zlib.crc32(key.encode())]


def _drawable(item, h) -> bool:
    """Whether ``h``'s parameters that can absorb ``item`` can be drawn: none, or a
    covariance for them."""
    keys = [k for k, _ in h.absorbing(item.source)]
    return not keys or h.covariance(keys) is not None


def replicate_separations(direction: Direction, k: int, n: int = REPLICATES,
                          seed=None) -> np.ndarray | None:
    """The separations ``chi2_rival - chi2_truth`` of ``n`` simulated recordings of
    ``k`` repeats of the direction's item under its truth (module doc); None when the
    parameters cannot be drawn (a hypothesis with parameters that absorb the recording
    but no covariance for them).  ``seed``: default from the item, ``k`` and the pair."""
    item, truth, rival = direction.item, direction.truth, direction.rival
    if not (_drawable(item, truth) and _drawable(item, rival)):
        return None
    W, Wk = direction.W, direction.whitening(k)
    t, r = _Refit(item, truth, W, Wk), _Refit(item, rival, W, Wk)
    rng = np.random.default_rng(_seed(direction, k) if seed is None else seed)
    # noise only where the whitening measures something (a row of zeros carries nothing)
    Wa = np.asarray(Wk, dtype=float)
    mask = (Wa != 0) if Wa.ndim == 1 else np.any(Wa != 0, axis=1)
    mask = np.broadcast_to(mask, white(Wk, item.vector(truth)).shape)
    if t.model is not None:
        lam, V = np.linalg.eigh(t.model.C)
        root = V * np.sqrt(np.clip(lam, 0.0, None))
    # the rival's refit to the truth's predicted recording (noise-free), once: each
    # replicate starts from it moved linearly by the replicate's own deviation from that
    # recording; the truth's starts from the drawn parameters moved by the noise and pulled
    # back by the information.  Both start near their optimum: few predictions each.
    v_t = item.vector(truth)
    _, x_rival = r.fit(v_t, np.zeros(mask.shape), Wk)
    out = np.empty(n)
    for i in range(n):
        delta = None if t.model is None else root @ rng.standard_normal(root.shape[1])
        v_obs = item.vector(truth, None if t.model is None else t.params(delta))
        noise = np.where(mask, rng.standard_normal(mask.shape), 0.0)
        x0 = None if r.model is None else x_rival + r.step(white(Wk, v_obs - v_t) + noise)
        chi2_rival = r.fit(v_obs, noise, Wk, x0)[0]
        # at the drawn parameters the residuals are the noise: one Newton step from there
        x0 = None if t.model is None else delta + np.linalg.lstsq(
            t.A, t.Jk.T @ noise - t.model.Cinv @ delta, rcond=None)[0]
        out[i] = chi2_rival - t.fit(v_obs, noise, Wk, x0)[0]
    return out


def summary(separations) -> dict | None:
    """``{"median", "p10", "n"}`` of the finite ``separations`` (``p10``: their
    :data:`PERCENTILE`-th percentile); None when fewer than half are finite."""
    s = np.asarray(separations, dtype=float)
    s = s[np.isfinite(s)]
    if s.size == 0 or 2 * s.size < np.size(separations):
        return None
    return {"median": float(np.median(s)), "p10": float(np.percentile(s, PERCENTILE)),
            "n": int(s.size)}
