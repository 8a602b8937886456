"""Thermal initial state of the mode and the Fock-space cutoff of the integration.

* Thermal state ``p_m = nbar^m/(1+nbar)^{m+1}``, truncated at
  ``m_max`` where the neglected tail ``(nbar/(1+nbar))^{m_max+1} < 1e-10``,
  renormalised.
* Fock cutoff (``n_fock=None``): a bound ``B`` on the spin-dependent
  displacement from the triangle inequality,
  ``B = 2 (eta Omega0/2) max(sum_n |b_n| w_n, sum_n |c_n| w_n)``,
  ``w_n = min(2/|delta_n|, t_max)`` (``2`` ions; ``1`` for one ion), and the
  smallest ``n_fock`` for which the displaced thermal state
  ``sum_m p_m D(B)|m><m|D(B)^dag`` (computed numerically) puts less than
  1e-14 of population on the levels ``>= n_fock - 1``.  The integration
  checks the cutoff along the way (:mod:`dpdfit.models.gate_sim.evolve`).
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy.linalg import expm

from .arguments import check_tones, positive

__all__ = ["THERMAL_TAIL", "thermal_levels", "thermal_weights", "displacement_bound",
           "fock_cutoff"]

#: Neglected thermal tail weight.
THERMAL_TAIL = 1e-10
_RULE_TOL = 1e-14        # displaced thermal population allowed on levels >= n_fock - 1
# above this displacement bound (or 800 thermal levels) the cutoff is the closed-form rule,
# capped at _MAX_FOCK: such a Fock space never fits in memory, and the size guard refuses it
_CLOSED_FORM_B = 1e9
_MAX_FOCK = 10 ** 18


def thermal_levels(nbar, tail=THERMAL_TAIL) -> int:
    """Number of thermal Fock levels ``m_max + 1`` that :func:`thermal_weights` keeps,
    without making them (the size of the engine's state is checked before it is made)."""
    nbar = positive("nbar", nbar, allow_zero=True)
    if nbar == 0:
        return 1
    q = nbar / (1.0 + nbar)
    if q == 1.0:                                   # nbar beyond 1e16: no finite truncation
        return _MAX_FOCK
    m_max = max(0, int(math.ceil(math.log(tail) / math.log(q))) - 1)
    if m_max > 10 ** 7:                            # far beyond any memory: skip the rounding
        return min(m_max + 1, _MAX_FOCK)
    while q ** (m_max + 1) >= tail:
        m_max += 1
    while m_max > 0 and q ** m_max < tail:
        m_max -= 1
    return m_max + 1


def thermal_weights(nbar, tail=THERMAL_TAIL):
    """Thermal Fock weights ``p_m``, ``m = 0..m_max`` (tail < ``tail``), renormalised.

    Parameters
    ----------
    nbar : float
        Mean phonon number (>= 0).
    tail : float
        Largest neglected weight ``(nbar/(1+nbar))^(m_max+1)``.
    """
    nbar = positive("nbar", nbar, allow_zero=True)
    if nbar == 0:
        return np.array([1.0])
    q = nbar / (1.0 + nbar)
    p = (1.0 - q) * q ** np.arange(thermal_levels(nbar, tail))
    return p / p.sum()


def displacement_bound(b, c, n, eta_Omega0, xi0, t_max=None, n_ions=2):
    """Triangle-inequality bound on the spin-dependent displacement up to ``t_max``.

    ``B = n_ions (eta Omega0/2) max(sum |b_n| w_n, sum |c_n| w_n)``,
    ``w_n = min(2/|delta_n|, t_max)`` (``t_max`` for ``n = 0``); dimensionless
    (units of the zero-point amplitude).  ``t_max`` defaults to ``1/xi0``.
    """
    b, c, n = check_tones(b, c, n)
    t_max = 1.0 / xi0 if t_max is None else float(t_max)
    delta = np.abs(2 * np.pi * n * xi0)
    w = np.where(n == 0, t_max, np.minimum(2.0 / np.where(n == 0, 1.0, delta), t_max))
    return n_ions * 0.5 * eta_Omega0 * max(float(np.sum(np.abs(b) * w)),
                                           float(np.sum(np.abs(c) * w)))


@functools.lru_cache(maxsize=256)
def _cutoff_cached(B_key: int, nbar_key: float, tol: float, tail: float) -> int:
    B = B_key / 1000.0
    p = thermal_weights(nbar_key, tail)
    m_max = p.size - 1
    big = int(math.ceil((math.sqrt(m_max) + B) ** 2 + 20 * B + 80))
    if big > 800:          # huge displacement: conservative closed-form rule instead
        x = math.sqrt(m_max) + B
        return int(math.ceil(x * x + 12.0 * B + 20.0))
    k = np.arange(1, big)
    gen = np.diag(B * np.sqrt(k), -1) - np.diag(B * np.sqrt(k), 1)   # B (a^dag - a)
    D = expm(gen)[:, :m_max + 1]
    pop = np.abs(D) ** 2 @ p                       # displaced thermal populations
    tail = np.cumsum(pop[::-1])[::-1]              # tail[k] = population on levels >= k
    ok = np.nonzero(tail < tol)[0]
    # levels >= n_fock - 1 carry < tol; keep >= 4 levels above the thermal m_max
    n_fock = int(ok[0]) + 1 if ok.size else big
    return max(n_fock, m_max + 5, 6)


def fock_cutoff(nbar, B, tol=_RULE_TOL, tail=THERMAL_TAIL):
    """Fock dimension for a thermal state displaced by up to ``B`` (module docstring);
    ``tail``: the thermal weights' neglected tail."""
    B = max(float(B), 0.0)
    levels = thermal_levels(nbar, tail)
    if not B < _CLOSED_FORM_B or levels > 800:     # the closed-form rule (below), unrounded
        x = math.sqrt(levels - 1) + B
        return int(min(x * x + 12.0 * B + 20.0, _MAX_FOCK))
    return _cutoff_cached(int(math.ceil(B * 1000)), float(nbar), float(tol), float(tail))
