"""Ramsey and spin-echo outcomes of the two-ion chain (``ramsey.csv``'s physics).

Both ions start in ``00``; a pi/2 pulse, a free-precession wait ``t``, a pi/2 pulse in
phase with the first; the echo adds a pi pulse about the orthogonal axis at ``t/2``.  In
both sequences an ion that kept its coherence ends dark (``1``): an ion prepared in ``0``
reads dark with probability ``(1 + cos phi)/2``, one prepared in ``1`` (a flip) with
``(1 - cos phi)/2``, where ``phi`` is the phase it picked up; a spectator (a level outside
the qubit, driven by no pulse) reads bright.  Pulse errors are neglected.

Dephasing: each ion's phase is Gaussian, ``phi_j = a_j + c`` with an independent part
``a_j`` and a part ``c`` common to both (a magnetic field), of variances ``2 G_i`` and
``2 G_c`` (``G`` the accumulated dephasing: ``exp(-G)`` of a coherence).  So
``<cos phi_j> = exp(-(G_i + G_c))`` and ``<cos phi_1 cos phi_2> = (exp(-2 G_i) +
exp(-2 G_i - 4 G_c)) / 2``: the two-ion outcome ``n01_10`` tells common from independent
noise, as ``|01><10|`` and ``|00><11|`` of the gate engine do
(:mod:`dpdfit.models.gate_sim.dephasing`).

What the echo removes (:func:`free_dephasing`) -- the assumption, stated once for the
simulator and the diagnosis: dephasing of a constant rate (``beta = 1``: white,
Markovian noise, the engine's ``T2`` and ``T2_corr``) is not refocused; a compressed
exponential (``beta > 1``: slow noise, ``beta = 2`` a frequency offset constant over a
shot) is refocused completely, its correlation time taken as longer than the longest
wait; a stretched one (``beta < 1``: broadband noise, faster than the wait) is not
refocused.  Partial refocusing of noise whose correlation time lies within the scan is
outside this model.

Preparation and detection errors enter as in the SPAM characterisation: per ion a
spectator with probability ``spectator``, flipped with ``flip``; each reading flipped
with ``e01`` (bright read dark) and ``e10`` (dark read bright).
"""

from __future__ import annotations

import numpy as np

from dpdfit.models.gate_sim.dephasing import accumulated_dephasing

__all__ = ["SEQUENCES", "SCAN_POINTS", "scan_waits", "refocused", "free_dephasing",
           "ramsey_probabilities"]

#: the sequences, as ``ramsey.csv`` names them
SEQUENCES = ("ramsey", "echo")
#: waits per sequence of a Ramsey scan (the first at zero)
SCAN_POINTS = 20


def scan_waits(T2: float, points: int = SCAN_POINTS) -> np.ndarray:
    """The waits (s) of a scan for a coherence time ``T2`` (s): zero, then ``points - 1``
    geometric from ``T2/2500`` (20 us at 50 ms: slow noise decays within a few ms) to
    ``1.5 T2``, rounded to the ns."""
    grid = np.geomspace(T2 / 2500.0, 1.5 * T2, int(points) - 1)
    return np.round(np.concatenate([[0.0], grid]), 9)


def refocused(beta: float) -> bool:
    """Whether the echo removes dephasing of time-profile exponent ``beta`` (module doc:
    slow noise, ``beta > 1``)."""
    return float(beta) > 1.0 + 1e-9


def free_dephasing(rate: float, beta: float, t_ref: float, t, echo: bool) -> np.ndarray:
    """Accumulated dephasing ``G(t) = rate t_ref (t/t_ref)^beta`` of one ion over a free
    wait ``t`` (s), after the echo when ``echo`` (zero where :func:`refocused`)."""
    t = np.asarray(t, dtype=float)
    if echo and refocused(beta):
        return np.zeros(t.shape)
    return accumulated_dephasing(rate, beta, t_ref, t)


def _ion_dark(kind: int, k1):
    """Probability that one ion reads dark (before detection errors): ``kind`` +1 an ion
    started in ``0``, -1 a flipped one, 0 a spectator."""
    return np.zeros_like(k1) if kind == 0 else (1 + kind * k1) / 2


def ramsey_probabilities(G_ind, G_com, spectator: float = 0.0, flip: float = 0.0,
                         e01: float = 0.0, e10: float = 0.0) -> np.ndarray:
    """``(len(t), 3)``: detected ``P00, P01_10, P11`` (``0`` bright) after a wait with
    accumulated independent and common dephasing ``G_ind``, ``G_com`` per ion (arrays over
    the waits; module doc)."""
    G_i, G_c = np.broadcast_arrays(np.asarray(G_ind, dtype=float),
                                   np.asarray(G_com, dtype=float))
    k1 = np.exp(-(G_i + G_c))
    kk = (np.exp(-2 * G_i) + np.exp(-2 * G_i - 4 * G_c)) / 2     # <cos phi_1 cos phi_2>
    branches = ((1.0 - spectator - flip, 1), (flip, -1), (spectator, 0))
    dd = np.zeros(k1.shape)        # both dark
    d1 = np.zeros(k1.shape)        # the first dark (the second either way)
    for w1, s1 in branches:
        a = _ion_dark(s1, k1)
        d1 = d1 + w1 * a
        for w2, s2 in branches:
            b = _ion_dark(s2, k1)
            both = (1 + (s1 + s2) * k1 + s1 * s2 * kk) / 4 if s1 and s2 else a * b
            dd = dd + w1 * w2 * both
    # true outcomes (bright-bright, one dark, dark-dark); the ions alike, so the first's
    # dark probability d1 is the second's too
    bd = d1 - dd
    bb = 1 - 2 * d1 + dd
    C = np.array([[1 - e01, e10], [e01, 1 - e10]])              # C[read, true], 0 bright
    true = np.stack([np.stack([bb, bd], -1), np.stack([bd, dd], -1)], -2)   # [..., x, y]
    read = np.einsum("ax,by,...xy->...ab", C, C, true)
    return np.stack([read[..., 0, 0], read[..., 0, 1] + read[..., 1, 0], read[..., 1, 1]],
                    axis=-1)
