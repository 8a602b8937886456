"""Interpolation in uniform tables, the inner loop of the tone model's engines."""

from __future__ import annotations

import numpy as np
from scipy.sparse import csr_matrix

__all__ = ["uniform_interp", "uniform_place", "uniform_at", "cubic_interp", "cubic_weights", "cubic_apply", "CubicWeights"]


def uniform_interp(x, table, slopes=None):
    """Linear interpolation in a table (real or complex) on the uniform grid 0..1 (as
    the AWG applies it); ``slopes``: ``table[1:] - table[:-1]`` when the caller has it
    (one lookup instead of two, the same values).

    Hand-written because ``np.interp`` bisects for every sample (and takes real
    tables only); on a uniform grid the index is arithmetic (5-10x faster).
    """
    n = table.size - 1
    if slopes is not None:
        return uniform_at(uniform_place(x, n), table, slopes)
    u = np.clip(x, 0.0, 1.0) * n
    i = np.minimum(u.astype(np.intp), n - 1)
    f = u - i
    t0 = table[i]
    return t0 + f * (table[i + 1] - t0)


def uniform_place(x, n: int):
    """The places of ``x`` in a uniform table of ``n + 1`` points on 0..1: ``(i, f)``, the
    interval and the fraction in it (:func:`uniform_at`; fixed samples, any table)."""
    u = np.clip(x, 0.0, 1.0) * n
    i = np.minimum(u.astype(np.intp), n - 1)
    return i, u - i


def uniform_at(where, table, slopes):
    """:func:`uniform_interp` at places ``where`` (:func:`uniform_place`) of ``table`` with
    its ``slopes`` (``table[1:] - table[:-1]``)."""
    i, f = where
    return table[i] + f * slopes[i]


class CubicWeights:
    """The indices and Lagrange weights of :func:`cubic_interp` at fixed points ``x`` for
    a table of ``K + 1`` points, for :func:`cubic_apply` (computed once for any number
    of tables), held as a sparse matrix (four weights a row, in the order the sum adds
    them: the same values as the gathers of :func:`cubic_interp`, several times faster)."""

    def __init__(self, x: np.ndarray, K: int):
        x = np.asarray(x, dtype=float)
        s = np.clip(x, 0.0, 1.0) * K
        i = np.clip(np.floor(s).astype(np.intp) - 1, 0, K - 3)
        f = s - i
        l0 = -(f - 1) * (f - 2) * (f - 3) / 6
        l1 = f * (f - 2) * (f - 3) / 2
        l2 = -f * (f - 1) * (f - 3) / 2
        l3 = f * (f - 1) * (f - 2) / 6
        self.shape = x.shape
        n = x.size
        cols = (i.reshape(-1, 1) + np.arange(4)).ravel()
        vals = np.stack([l.ravel() for l in (l0, l1, l2, l3)], axis=1).ravel()
        self.matrix = csr_matrix((vals, cols, np.arange(0, 4 * n + 1, 4)), shape=(n, K + 1))


def cubic_weights(x: np.ndarray, K: int) -> CubicWeights:
    """The cubic interpolation weights of :func:`cubic_interp` at ``x`` for a table of
    ``K + 1`` points (:class:`CubicWeights`)."""
    return CubicWeights(x, K)


def cubic_apply(table: np.ndarray, weights: CubicWeights) -> np.ndarray:
    """Cubic Lagrange interpolation of ``table`` (last axis: uniform grid on [0, 1]) with
    the weights :func:`cubic_weights` gave: shape ``table.shape[:-1] + x.shape``."""
    lead = table.shape[:-1]
    flat = table.reshape(-1, table.shape[-1])
    out = weights.matrix @ flat.T                      # (points, tables)
    return np.ascontiguousarray(out.T).reshape(lead + weights.shape)


def cubic_interp(table: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Cubic Lagrange interpolation of ``table`` (last axis: uniform grid on [0, 1]) at
    ``x`` in [0, 1] (hand-written: vectorised over the leading table axis)."""
    return cubic_apply(table, cubic_weights(x, table.shape[-1] - 1))
