"""State preparation and detection errors: preparation branches, their mixing, readout confusion.

* **State preparation** (``p_prep`` per ion, default 0.003): with
  probability ``p_prep`` an ion is pumped into the other Zeeman sublevel of
  S1/2; it is driven neither by the gate nor by the analysis pulse and reads
  bright (``|0>``).  The four branches are computed exactly: both ions good
  ``(1-p)^2`` (two-ion dynamics), one ion out ``2 p (1-p)`` (the other ion is
  propagated alone under the same drive, dephasing and heating: single-spin
  dynamics), both out ``p^2`` (both bright).
* **Detection** (``p_det`` per ion, default 5e-5): each ion's bright/dark
  result is flipped with probability ``p_det``, independently: confusion
  matrix ``C (x) C``, ``C = [[1-p, p], [p, 1-p]]`` on the four outcomes.
"""

from __future__ import annotations

import functools

import numpy as np

from dpdfit.errors import InputError

from .arguments import probability
from .dephasing import dephase_coherences
from .evolve import evolve, evolve_lindblad

__all__ = ["confusion", "mix_branches", "spectator_outcomes", "branch_states", "mixed_outcomes",
           "prep_probabilities", "detection_errors"]


def confusion(p4, p_det):
    """Apply independent per-ion readout errors to 4-outcome (or 2-outcome) probabilities.

    ``p_det`` is one probability (symmetric) or a pair ``(e01, e10)``: ``e01``
    the probability that a bright ``|0>`` ion reads dark (1), ``e10`` that a
    dark ``|1>`` ion reads bright (0).
    """
    p4 = np.asarray(p4, dtype=float)
    e01, e10 = (p_det, p_det) if np.ndim(p_det) == 0 else (float(p_det[0]), float(p_det[1]))
    C = np.array([[1 - e01, e10], [e01, 1 - e10]])           # C[read, true]
    return p4 @ (np.kron(C, C).T if p4.shape[-1] == 4 else C.T)


def spectator_outcomes(p1):
    """Four outcomes of 'one ion a spectator (reads 0), the other driven' summed over
    which ion is out: ``p1`` (..., 2) are the driven ion's outcomes."""
    p1 = np.asarray(p1, dtype=float)
    one = np.zeros(p1.shape[:-1] + (4,))
    # ion 1 out (reads 0), ion 2 driven: outcomes 00, 01
    one[..., 0] += p1[..., 0]
    one[..., 1] += p1[..., 1]
    # ion 2 out, ion 1 driven: outcomes 00, 10
    one[..., 0] += p1[..., 0]
    one[..., 2] += p1[..., 1]
    return one


def mix_branches(p2, p1, p_prep, p_flip=0.0, p2_01=None, p2_11=None, p1_1=None):
    """Four-outcome probabilities from the preparation branches.

    Each ion is independently a *spectator* with probability ``p_prep`` (pumped
    into a level that takes no part in the gate; reads bright, 0), prepared in
    the wrong qubit state ``|1>`` with probability ``p_flip`` (driven by the
    gate), and right otherwise.  ``p2``: (..., 4) outcomes of the two-ion
    branch from ``|00>``; ``p1``: (..., 2) of one driven ion from ``|0>``;
    ``p2_01``: two ions from ``|01>`` (``|10>`` is its mirror: the ions are
    driven alike); ``p2_11``: from ``|11>`` (None: ``p2`` with both bits flipped,
    exact for the ideal interaction, which anticommutes with ``X X``, and of
    weight ``p_flip^2`` anyway); ``p1_1``: one driven ion from ``|1>``.
    """
    q, f = p_prep, p_flip
    g = 1.0 - q - f
    out = g ** 2 * np.asarray(p2, dtype=float)
    if q > 0:
        out = out + q * g * spectator_outcomes(p1)
        out[..., 0] += q ** 2
    if f > 0:
        p01 = np.asarray(p2_01, dtype=float)
        out = out + f * g * (p01 + p01[..., [0, 2, 1, 3]])
        p11 = (np.asarray(p2, dtype=float)[..., ::-1] if p2_11 is None
               else np.asarray(p2_11, dtype=float))
        out = out + f * f * p11
        if q > 0:
            out = out + q * f * spectator_outcomes(p1_1)
    return out


def branch_states(b, c, n, eta_Omega0, xi0, times, nbar, T2, ndot, p_prep, n_fock, rtol, atol,
                  p_flip=0.0, T2_corr=np.inf, dephasing_profile=None, coherence=None):
    """Spin states of the preparation branches at ``times``.

    Returns ``(rho2, rho1, info, flips)``: the two-ion branch from ``|00>``,
    the single driven ion from ``|0>`` (if ``p_prep > 0``: the other ion is a
    spectator) and, if ``p_flip > 0``, ``flips = (rho2 from |01>, rho2 from |11>,
    rho1 from |1>)`` (ions prepared in the wrong qubit state; the last only if
    ``p_prep > 0`` too), else None.  Slow dephasing
    (:mod:`dpdfit.models.gate_sim.dephasing`): ``dephasing_profile`` during the gate
    (:func:`~dpdfit.models.gate_sim.evolve.evolve_lindblad`), ``coherence`` the factors
    ``(k1, k2)`` of every state's coherences after it (its populations untouched).
    """
    lind = not (np.isinf(T2) and ndot == 0 and np.isinf(T2_corr)
                and dephasing_profile is None)
    kw = dict(n_fock=n_fock, rtol=rtol, atol=atol, return_info=True)
    if lind:
        f = functools.partial(evolve_lindblad, T2=T2, ndot=ndot, T2_corr=T2_corr,
                              dephasing_profile=dephasing_profile)
    else:
        f = evolve
    rho2, info2 = f(b, c, n, eta_Omega0, xi0, times, nbar, n_ions=2, **kw)
    rho1 = info1 = None
    if p_prep > 0:
        rho1, info1 = f(b, c, n, eta_Omega0, xi0, times, nbar, n_ions=1, **kw)
    flips = None
    if p_flip > 0:
        r01, _ = f(b, c, n, eta_Omega0, xi0, times, nbar, n_ions=2, initial=1, **kw)
        r11, _ = f(b, c, n, eta_Omega0, xi0, times, nbar, n_ions=2, initial=3, **kw)
        r1f = None
        if p_prep > 0:
            r1f, _ = f(b, c, n, eta_Omega0, xi0, times, nbar, n_ions=1, initial=1, **kw)
        flips = (r01, r11, r1f)
    if coherence is not None:
        def dephase(r):
            return None if r is None else dephase_coherences(r, *coherence)
        rho2, rho1 = dephase(rho2), dephase(rho1)
        flips = None if flips is None else tuple(dephase(r) for r in flips)
    return rho2, rho1, {"two_ion": info2, "one_ion": info1, "master_equation": lind}, flips


def mixed_outcomes(rho2, rho1, flips, p_prep, p_flip, reduce):
    """Mixed four-outcome probabilities of the branches, ``reduce`` = outcome map of a state."""
    o1 = None if rho1 is None else reduce(rho1)
    if flips is None:
        return mix_branches(reduce(rho2), o1, p_prep)
    r01, r11, r1f = flips
    return mix_branches(reduce(rho2), o1, p_prep, p_flip, reduce(r01), reduce(r11),
                        None if r1f is None else reduce(r1f))


def prep_probabilities(p_prep, p_flip):
    """Checked ``(p_prep, p_flip)``: each in [0, 1], their sum <= 1."""
    p_prep = probability("p_prep", p_prep)
    p_flip = probability("p_flip", p_flip)
    if p_prep + p_flip > 1:
        raise InputError(f"p_prep + p_flip must not exceed 1, got {p_prep + p_flip}")
    return p_prep, p_flip


def detection_errors(p_det):
    """Checked ``p_det``: one probability or a pair ``(e01, e10)``."""
    if np.ndim(p_det) == 0:
        return probability("p_det", p_det)
    if np.shape(p_det) != (2,):
        raise InputError(f"p_det must be a probability or a pair (e01, e10), got {p_det!r}")
    return (probability("e01", p_det[0]), probability("e10", p_det[1]))
