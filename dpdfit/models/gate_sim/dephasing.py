"""Dephasing that is not a constant Markovian rate: a time profile, or decay after the gate.

The engine's own qubit dephasing (``T2``, ``T2_corr``) is white ``sigma_z`` noise: each
ion's coherence decays as ``exp(-t/T2)``.  Slow (e.g. 1/f-like or quasi-static) phase
noise gives a decay ``exp(-G(t))`` whose exponent is not linear in time,

.. math:: G(t) = \\Gamma\\, t_\\mathrm{ref}\\,(t/t_\\mathrm{ref})^\\beta ,

(``beta = 2`` for quasi-static Gaussian noise: a random frequency offset per shot).  Two
ways of injecting such noise are provided:

* **During the gate** (:func:`profile_rates`): a time-local dephasing rate
  ``gamma(t) = dG/dt = beta Gamma (t/t_ref)^(beta-1)`` in the master equation.  For pure
  dephasing under Gaussian noise that is exact (the time-convolutionless generator of a
  freely evolving qubit); with the gate's drive on it is the usual weak-noise
  approximation.  A time scan read from one integration then sees ``G(t)`` accumulated up
  to each of its times, as a gate stopped at ``t`` would.  For ``beta < 1`` the rate
  diverges at ``t = 0`` (integrably); below ``1e-6 t_ref`` it is held at the mean rate of
  that interval, so that ``G`` is exact from there on.
* **On the final state only** (:func:`dephase_coherences`): noise too slow to act within
  the gate's loops, or acting between the gate and the analysis pulse, multiplies the
  final state's coherences and leaves its populations alone.

:func:`~dpdfit.models.gate_sim.setting.simulate_setting` takes them as
``dephasing_profile = (rate, rate_common, beta, t_ref)`` (rates of the independent and
the common noise at ``t_ref``) and ``coherence = (k1, k2)`` (factors of a single-ion and
of the ``|00><11|`` coherence).

A fraction of the noise may be common to both ions (a magnetic field): with independent
and common Gaussian phases of variances ``2 G_i`` and ``2 G_c`` per ion, ``|00><01|`` and
the like decay by ``exp(-(G_i + G_c))``, ``|00><11|`` by ``exp(-2 G_i - 4 G_c)`` and
``|01><10|`` by ``exp(-2 G_i)``.
"""

from __future__ import annotations

import numpy as np

from dpdfit.errors import InputError

__all__ = ["check_dephasing_profile", "accumulated_dephasing", "profile_rates",
           "dephase_coherences", "T_FLOOR"]

#: below this fraction of ``t_ref`` a profile's rate is held constant (``beta < 1``)
T_FLOOR = 1e-6


def check_dephasing_profile(profile) -> tuple:
    """``(rate, rate_common, beta, t_ref)`` as floats: rates in 1/s at ``t_ref`` (>= 0),
    ``beta > 0``, ``t_ref`` (s) > 0; an InputError naming what is wrong otherwise."""
    try:
        rate, rate_c, beta, t_ref = (float(x) for x in profile)
    except (TypeError, ValueError):
        raise InputError(f"dephasing_profile must be (rate, rate_common, beta, t_ref), "
                         f"got {profile!r}") from None
    if not (np.isfinite(rate) and rate >= 0 and np.isfinite(rate_c) and rate_c >= 0):
        raise InputError(f"dephasing_profile rates must be finite and >= 0, got "
                         f"{rate}, {rate_c}")
    if not (np.isfinite(beta) and beta > 0 and np.isfinite(t_ref) and t_ref > 0):
        raise InputError(f"dephasing_profile needs beta > 0 and t_ref > 0 (s), got "
                         f"beta {beta}, t_ref {t_ref}")
    return rate, rate_c, beta, t_ref


def accumulated_dephasing(rate: float, beta: float, t_ref: float, t) -> np.ndarray:
    """``G(t) = rate t_ref (t/t_ref)^beta`` at times ``t`` (s): each ion's coherence decays
    by ``exp(-G)``."""
    t = np.maximum(np.asarray(t, dtype=float), 0.0)
    return rate * t_ref * (t / t_ref) ** beta


def profile_rates(profile, xi0: float):
    """The time-local rates of a profile per unit of the engine's time ``tau = t xi0``.

    Returns a function ``tau -> (gamma_independent, gamma_common)``, the coefficients of
    the engine's dissipator for Lindblad ``Z_j`` and ``Z_1 + Z_2`` noise at that time
    (see the module doc).
    """
    rate, rate_c, beta, t_ref = check_dephasing_profile(profile)
    t0 = T_FLOOR * t_ref
    # held below t0 at G(t0)/t0: the rate that accumulates G exactly by t0
    floor = (t0 / t_ref) ** (beta - 1)

    def rates(tau):
        t = tau / xi0
        f = beta * (t / t_ref) ** (beta - 1) if t > t0 else floor
        return rate * f / xi0, rate_c * f / xi0

    return rates


def dephase_coherences(rho, k1, k2) -> np.ndarray:
    """The spin state(s) ``rho`` (..., 4, 4) or (..., 2, 2) with their coherences decayed.

    ``k1``: factor of a single-ion coherence (elements differing in one ion); ``k2``: of
    ``|00><11|``.  ``|01><10|`` decays by ``k1^4 / k2``, what Gaussian phase noise with
    those two factors gives (module doc); populations are untouched.
    """
    k1, k2 = float(k1), float(k2)
    if not (0.0 <= k1 <= 1.0 and 0.0 <= k2 <= 1.0):
        raise InputError(f"coherence factors must lie in [0, 1], got {k1}, {k2}")
    rho = np.asarray(rho)
    d = rho.shape[-1]
    lab = np.arange(d)
    dist = np.zeros((d, d), dtype=int)
    for j in range(int(np.log2(d))):
        bit = (lab >> j) & 1
        dist += bit[:, None] != bit[None, :]
    m = np.where(dist == 1, k1, 1.0)
    if d == 4:
        k_anti = k1 ** 4 / k2 if k2 > 0 else 0.0
        m[0, 3] = m[3, 0] = k2
        m[1, 2] = m[2, 1] = min(k_anti, 1.0)
    return rho * m
