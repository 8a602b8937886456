"""Arithmetic of the model's parity fringes on the analysis phases ``PHASES``.

The fringe of a setting is a combination of ``1, cos phi, sin phi, cos 2phi,
sin 2phi``; on 16 equally spaced phases these are orthogonal, so the
contrast and the decay of a coherence are exact linear maps of the fringe.
"""

from __future__ import annotations

import numpy as np

from dpdfit.core.defaults import ERROR_MODEL

__all__ = ["PHASES", "collapse", "contrast", "decohere"]

#: analysis phases of the model's fringes (the contrast does not depend on them): the
#: lab's ``ERROR_MODEL.parity_phases`` (16) equally spaced phases
PHASES = ERROR_MODEL.analysis_phases()

# design of the fringe fit: 1, cos phi, sin phi, cos 2phi, sin 2phi (exact on PHASES)
_DESIGN = np.stack([np.ones_like(PHASES), np.cos(PHASES), np.sin(PHASES), np.cos(2 * PHASES),
                    np.sin(2 * PHASES)], axis=1)
_PINV = np.linalg.pinv(_DESIGN)[3:5]                 # rows giving the cos/sin 2phi coefficients


def collapse(p4):
    """Two-ion outcome probabilities (..., 4: 00, 01, 10, 11) as (even population, P00 - P11)."""
    return p4[..., 0] + p4[..., 3], p4[..., 0] - p4[..., 3]


def contrast(par4):
    """``cos 2 phi`` amplitude of the parity ``2 (P00 + P11) - 1`` over PHASES (last-but-one axis)."""
    parity = 2 * (par4[..., 0] + par4[..., 3]) - 1
    c = np.einsum("ij,...j->...i", _PINV, parity)
    return np.hypot(c[..., 0], c[..., 1])


def decohere(par, k1, k2):
    """Fringes ``par`` (rows, PHASES, outcomes) with their ``phi`` harmonic scaled by
    ``k1`` and their ``2 phi`` harmonic by ``k2`` (per row): the final state's
    single-ion and two-ion coherences decayed, its populations kept (exact on PHASES)."""
    c = np.einsum("kj,rjo->rko", np.linalg.pinv(_DESIGN), par)      # (rows, 5, outcomes)
    k1 = np.asarray(k1, dtype=float).reshape(-1, 1)
    k2 = np.asarray(k2, dtype=float).reshape(-1, 1)
    c = c.copy()
    c[:, 1:3] *= k1[:, None]
    c[:, 3:5] *= k2[:, None]
    return np.einsum("jk,rko->rjo", _DESIGN, c)
