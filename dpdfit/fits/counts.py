"""Raw-count inference of Bell-state fidelities (Supplement S7).

From the raw counts of a Bell-state experiment -- a population measurement
(even-parity outcomes ``n_even = n00 + n11`` of ``shots``) and parity-fringe
scans (even-parity counts ``k_i`` of ``n_i`` shots at analysis phases
``phi_i``) -- this module computes the population fidelity ``F_pop`` (S7.1),
the parity contrast ``F_par = A`` by binomial maximum likelihood (S7.2), the
combined fidelity (S7.3), and pools repeated scans at the count level (S7.4),
with error bars that stay honest near ``F = 1``.

Population fidelity
-------------------
``F_pop = n_even / shots`` is a single binomial proportion.  ``F_pop_err =
sqrt(F (1 - F) / N)`` is the paper's sigma (S7.1) and is always reported.
Near ``F = 1`` it is a poor error bar (it is exactly 0 when ``n_even ==
shots``), so every result also carries an interval that behaves there:
Wilson's score interval (default; nominal coverage on average) or
Clopper-Pearson's (``interval="clopper-pearson"``, from the beta
distribution; conservative: coverage >= nominal for every true F).  Both are
non-degenerate at ``n_even == shots`` (Wilson: ``[N/(N + z^2), 1]``, CP:
``[(alpha/2)^(1/N), 1]``, with the usual two-sided ``alpha = 1 - level``).
Exact coverage at N = 625 (binomial sums): averaged over F in [0.990,
0.999] Wilson 68.0 %, Clopper-Pearson 81.4 % (minimum 69.7 %), the paper's
``F +/- F_pop_err`` 64.8 % (minimum 44 %).  Coverage of a discrete binomial
oscillates with F: at exactly F = 0.995 Wilson gives 61.4 % and CP 86.0 %,
and Wilson dips to 37 % at some F in that range -- choose CP when a bound
must hold for every F.

Parity fit
----------
``Pi(phi) = A cos(2 phi + phi0)``; at each phase the probability of an even
outcome is ``p_i = (1 + A cos(2 phi_i + phi0)) / 2`` and the negative
log-likelihood ``-lnL = -sum k_i ln p_i + (n_i - k_i) ln(1 - p_i)`` (S7.2,
without the constant binomial coefficients) is minimised under ``|A| <= 1``.

*Optimiser.*  In ``(a, b) = (A cos phi0, -A sin phi0)`` the probabilities are
linear, ``p_i = (1 + a cos 2phi_i + b sin 2phi_i) / 2``, so ``-lnL`` is
convex and the feasible set ``a^2 + b^2 <= 1`` is a disk (on which every
``p_i`` lies in [0, 1]).  Start: weighted linear least squares of the
measured parity ``2 k_i/n_i - 1`` (radius capped at 0.99).  Then Newton
steps with the analytic gradient and Hessian whose quadratic model is
minimised *on the disk* (the plain Newton step when it stays inside,
otherwise the model's KKT point on the circle from its 2 x 2 secular
equation), with Armijo backtracking; every trial point is feasible (the disk
is convex) and points where some ``p_i`` is 0 against its counts have
``-lnL = inf`` and are rejected.  Iteration stops when the model decrease
``-g.s`` (the squared Newton decrement in the interior) is below 1e-14 or
the rounding level of ``-lnL`` -- the parameters are then within ~1e-7
sigma of the optimum.  Plain interior Newton with a fraction-to-boundary
rule is *not* enough: it can jam against the circle when the optimum is
interior but the model points outward.  An optimum on the circle is
polished by a 1-D solve on ``A = 1``, where ``-lnL(phi0) = -sum 2 k_i
ln|cos(u_i/2)| + 2 (n_i - k_i) ln|sin(u_i/2)|`` (``u_i = 2 phi_i + phi0``)
is strictly convex between its poles (where a ``p_i`` would be 0 against
counts that say otherwise): a bracketed Newton solve on the arc, accepted
when ``d(-lnL)/dA <= 0`` there (KKT: the likelihood still rises outward),
which makes it the global constrained optimum.  The MLE then sits on the
boundary ``A = 1`` (``on_boundary``; some ``p_i`` may be exactly 0 or 1
where the counts are all-even or all-odd).  The result is reported with
``A >= 0`` and ``phi0`` in (-pi, pi].  Checked against multi-start SLSQP on
1500 random data sets (3-16 phases, 1-700 shots, contrasts 0-1, perfect
fringes): never worse, within 2e-12 in ``-lnL``.

*Errors.*  ``A_err`` is the paper's: the inverse of the Hessian of ``-lnL``
in ``(A, phi0)`` from central finite differences with step 1e-5, after an
eigenvalue check of positive definiteness.  ``A_err_fisher`` is the
expected (Fisher) information at the optimum, ``I = sum n_i grad(p_i)
grad(p_i)^T / (p_i (1 - p_i))``, as a cross-check (it agrees with the
observed-information sigma to a few per cent when the fit is good).

*Boundary policy.*  The quadratic (Hessian) approximation of ``-lnL`` fails
when the contrast is within a few sigma of a physical boundary: near
``A = 1`` the likelihood is strongly skewed (the ``p_i`` of the fringe
extremes approach 0 and 1) and the MLE can sit on the boundary.  The
Hessian result (``method = "hessian"``, interval ``A -/+ z A_err``) is used
only when the Hessian is positive definite and ``A - BOUNDARY_SIGMAS *
A_err > 0`` and ``A + BOUNDARY_SIGMAS * A_err < 1`` (``BOUNDARY_SIGMAS =
3``).  Otherwise ``method = "profile"`` and ``flag`` says why: the interval
is the profile-likelihood interval ``{A : 2 [min_phi0 -lnL(A, phi0) -
min -lnL] <= chi2_1(level)}`` (``<= 1`` for 68.27 %), clipped to [0, 1], and
``A_err = max(A - A_lo, A_hi - A) / z`` (``z = 1`` at 68.27 %: the larger
one-sided distance, conservative as a symmetric error bar and never 0).  ``covariance``
is None in profile mode (the Hessian, if it could be computed, is kept in
``hessian``); ``phi0_err`` then is ``1/sqrt(d^2(-lnL)/dphi0^2)`` at the
optimum (conditional on A).

Measured (16 phases x 625 shots, random phi0; ``tests/test_counts.py``):
contrast 0.96 -- Hessian interval coverage 68.0 +/- 0.3 % (20000 scans),
bias +0.015 sigma, mean Hessian sigma / Cramer-Rao bound 0.999; contrast
0.995 -- 97 % profile, 11 % of the MLEs on A = 1, coverage of the reported
interval 69.1 +/- 0.5 % (10000 scans; the Hessian interval would cover
74 %); true contrast 1 -- coverage 86 % (a parameter on its boundary: the
0.5 chi2_0 + 0.5 chi2_1 mixture gives 84 %).

Pooling (S7.4)
--------------
Populations: ``n_even`` and ``shots`` are summed per setting ``(A, dpd)``
over scans (exact for any shot numbers; the raw counts are used, not
``round(F N)``).  Parity: phases are rounded to a common grid of 0.01 rad
(``m = round(phi / grid)``) and counts at the same grid point are summed;
the merged point is fitted at the shot-weighted mean of its raw phases
(within ``grid/2`` of the grid point; this avoids the up-to-0.005-rad
rounding error of fitting at the grid point itself, reported as
``phase_grid``).  The
scans of a setting *share the grid* when every two phases of different
scans either round to the same grid point (then they differ by less than
0.01 rad) or are at least ``near_miss = 0.05`` rad apart (different
analysis phases).  Two phases of different scans that round to different
grid points but are closer than 0.05 rad (e.g. one scan offset by 0.013 rad)
are a grid mismatch and refused with an :class:`InputError` naming the
rows.  A scan may hold a subset of the others' phases, or extra phases far
from them.  Phases are compared as given (no wrapping modulo pi or 2 pi).
"""

from __future__ import annotations

import functools
import logging
import math
import os
from dataclasses import dataclass, field, fields

import numpy as np
import pandas as pd
from scipy import stats

from dpdfit.errors import FitError, InputError
from dpdfit.recordings.tables import read_table

__all__ = [
    "LEVEL_1SIGMA", "FD_STEP", "BOUNDARY_SIGMAS", "PopulationFidelity", "population_fidelity",
    "ParityFit", "fit_parity", "parity_information", "combined_fidelity", "pool_populations",
    "merge_parity", "gate_fidelities", "read_populations", "read_parity",
    "GATE_COLUMNS",
]

#: Probability content of +/- 1 sigma of a normal distribution.
LEVEL_1SIGMA = math.erf(1 / math.sqrt(2))      # 0.6826894921370859
#: Finite-difference step of the Hessian of -lnL in (A, phi0) (as the paper).
FD_STEP = 1e-5
#: Hessian intervals are used only when A is more than this many sigma inside (0, 1).
BOUNDARY_SIGMAS = 3.0
#: Former grid-consistency threshold of :func:`merge_parity` (rad); kept for
#: compatibility, no longer used (scans are never refused for jittered phases).
NEAR_MISS = 0.05
#: A setting's scans failing the one-fringe likelihood-ratio test at this p get a warning.
SCAN_CONSISTENCY_ALPHA = 1e-3

log = logging.getLogger(__name__)
#: Columns of :func:`gate_fidelities`, in this order (extras follow).
GATE_COLUMNS = ["A", "dpd", "F_pop", "F_pop_err", "F_par", "F_par_err", "F", "F_err",
                "contrast", "phi0", "n_scans", "shots", "interval_method"]

_NEWTON_TOL = 1e-14         # model decrease -g.s (Newton decrement^2) at convergence
_MAX_NEWTON = 100


def _readonly(a):
    if a is None:
        return None
    arr = np.array(a, dtype=float, copy=True)
    arr.setflags(write=False)
    return arr


def _to_dict(obj) -> dict:
    out = {}
    for f in fields(obj):
        if f.name.startswith("_"):
            continue
        value = getattr(obj, f.name)
        if isinstance(value, np.ndarray):
            value = value.tolist()
        elif isinstance(value, tuple):
            value = list(value)
        elif isinstance(value, np.generic):
            value = value.item()
        out[f.name] = value
    return out


@functools.lru_cache(maxsize=64)
def _z(level: float) -> float:
    """Two-sided normal quantile: level = P(|Z| <= z)."""
    return float(stats.norm.ppf(0.5 + level / 2))


def _check_level(level) -> float:
    level = float(level)
    if not 0 < level < 1:
        raise InputError(f"level {level:g} must be in (0, 1)")
    return level


# ==========================================================================
# population fidelity (S7.1)
# ==========================================================================
@dataclass(frozen=True)
class PopulationFidelity:
    """Population fidelity ``F_pop = n_even / shots`` (S7.1) with an interval.

    Attributes
    ----------
    F_pop : float
        Even-parity fraction ``P00 + P11``.
    F_pop_err : float
        The paper's binomial sigma ``sqrt(F (1 - F) / N)``.  Exactly 0 when
        ``n_even == shots`` (or 0); use ``lo``/``hi`` then (see ``flag``).
    lo, hi : float
        Two-sided interval at ``level`` (``interval_method``: ``"wilson"`` or
        ``"clopper-pearson"``); non-degenerate also at ``n_even == shots``.
    interval_method : str
    level : float
        Coverage probability of the interval (default 68.27 %, 1 sigma).
    n_even, shots : int
    flag : str or None
        Set when the binomial sigma is 0 and only the interval is meaningful.
    """

    F_pop: float
    F_pop_err: float
    lo: float
    hi: float
    interval_method: str
    level: float
    n_even: int
    shots: int
    flag: str | None = None

    def to_dict(self) -> dict:
        """Plain-python (JSON-serialisable) copy of the fields."""
        return _to_dict(self)

    def report(self) -> str:
        """Readable one-block report."""
        lines = ["[[Population fidelity]]",
                 f"    n_even / shots     = {self.n_even} / {self.shots}",
                 f"    F_pop              = {self.F_pop:.6f} +/- {self.F_pop_err:.6f} "
                 "(binomial sigma, S7.1)",
                 f"    {self.level:.2%} interval = [{self.lo:.6f}, {self.hi:.6f}] "
                 f"({self.interval_method})"]
        if self.flag:
            lines.append(f"    note               = {self.flag}")
        return "\n".join(lines)


def _count(value, name: str) -> int:
    """A non-negative integer count (int, integral float or numpy scalar)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name} = {value!r} is not a number") from None
    if not math.isfinite(v) or v != round(v):
        raise InputError(f"{name} = {value!r} is not an integer count")
    if v < 0:
        raise InputError(f"{name} = {int(v)} is negative")
    return int(v)


def _binomial_interval(k, n, level: float, method: str):
    """Two-sided interval for a binomial proportion (arrays or scalars)."""
    k = np.asarray(k, dtype=float)
    n = np.asarray(n, dtype=float)
    alpha = 1.0 - level
    if method == "wilson":
        z = _z(level)
        z2 = z * z
        centre = (k + z2 / 2) / (n + z2)
        half = z * np.sqrt(k * (n - k) / n + z2 / 4) / (n + z2)
        lo, hi = centre - half, centre + half
        # exact values at the ends (the formula gives them up to rounding)
        lo = np.where(k == 0, 0.0, lo)
        hi = np.where(k == n, 1.0, hi)
    elif method == "clopper-pearson":
        with np.errstate(invalid="ignore"):
            lo = np.where(k > 0, stats.beta.ppf(alpha / 2, np.maximum(k, 1), n - k + 1), 0.0)
            hi = np.where(k < n, stats.beta.ppf(1 - alpha / 2, k + 1, np.maximum(n - k, 1)), 1.0)
    else:
        raise InputError(f"interval '{method}' unknown; use 'wilson' or 'clopper-pearson'")
    return np.clip(lo, 0.0, 1.0), np.clip(hi, 0.0, 1.0)


def _interval_name(interval: str) -> str:
    key = str(interval).lower().replace("_", "-").replace(" ", "-")
    aliases = {"wilson": "wilson", "clopper-pearson": "clopper-pearson", "cp": "clopper-pearson",
               "exact": "clopper-pearson"}
    if key not in aliases:
        raise InputError(f"interval '{interval}' unknown; use 'wilson' or 'clopper-pearson'")
    return aliases[key]


def population_fidelity(n_even, shots, interval: str = "wilson",
                        level: float = LEVEL_1SIGMA) -> PopulationFidelity:
    """Population fidelity ``F_pop = n_even / shots`` with sigma and interval (S7.1).

    Parameters
    ----------
    n_even : int
        Even-parity outcomes ``n00 + n11`` (a single binomial count).
    shots : int
        Repetitions ``N`` (> 0).
    interval : {"wilson", "clopper-pearson"}
        Interval method.  Wilson's score interval is close to nominal coverage
        on average and never degenerate; Clopper-Pearson (beta quantiles) is
        conservative: coverage >= ``level`` for every true F.
    level : float
        Two-sided coverage of the interval, default 0.682689 (1 sigma).

    Returns
    -------
    PopulationFidelity

    Notes
    -----
    When ``n_even == shots`` the binomial sigma is 0: it is still reported
    (it is the paper's formula) and ``flag`` says so; the interval is then
    ``[N/(N + z^2), 1]`` (Wilson) or ``[(alpha/2)^(1/N), 1]`` (CP).

    Examples
    --------
    >>> r = population_fidelity(625, 625)
    >>> r.F_pop, r.F_pop_err, round(r.lo, 5), r.hi
    (1.0, 0.0, 0.9984, 1.0)
    """
    k = _count(n_even, "n_even")
    n = _count(shots, "shots")
    if n <= 0:
        raise InputError("shots must be > 0 (a setting with no shots)")
    if k > n:
        raise InputError(f"n_even = {k} exceeds shots = {n}")
    method = _interval_name(interval)
    level = _check_level(level)
    F = k / n
    err = math.sqrt(F * (1 - F) / n)
    lo, hi = _binomial_interval(k, n, level, method)
    flag = None
    if k in (0, n):
        flag = (f"n_even = {k} of {n}: the binomial sigma sqrt(F(1-F)/N) is 0; "
                f"use the {method} interval [{float(lo):.6g}, {float(hi):.6g}]")
    return PopulationFidelity(F_pop=float(F), F_pop_err=float(err), lo=float(lo), hi=float(hi),
                              interval_method=method, level=level, n_even=k, shots=n, flag=flag)


# ==========================================================================
# parity fit (S7.2)
# ==========================================================================
@dataclass(frozen=True)
class ParityFit:
    """Binomial maximum-likelihood fit of ``Pi(phi) = A cos(2 phi + phi0)`` (S7.2).

    Attributes
    ----------
    A : float
        Fitted contrast, 0 <= A <= 1 (the sign is absorbed in ``phi0``).
        ``F_par`` is the same number.
    A_err : float
        1-sigma error of A: ``sqrt([H^-1]_AA)`` from the finite-difference
        Hessian (``method == "hessian"``), or ``max(A - A_lo, A_hi - A)`` of
        the profile-likelihood interval (``method == "profile"``).  Never 0
        or NaN.
    A_err_fisher : float
        ``sqrt([I^-1]_AA)`` from the expected (Fisher) information at the
        optimum (cross-check).  NaN when it is not defined (an optimum on
        the boundary with some ``p_i`` exactly 0 or 1: infinite information);
        ``flag`` then says so.
    phi0, phi0_err : float
        Phase offset in (-pi, pi] (rad) and its 1-sigma error (from the
        Hessian; in profile mode the curvature in phi0 at fixed A).
    covariance : ndarray (2, 2) or None
        Inverse Hessian in (A, phi0) when ``method == "hessian"``, else None.
    hessian : ndarray (2, 2) or None
        The finite-difference Hessian of -lnL in (A, phi0) (step 1e-5), when
        it could be evaluated (None when the stencil leaves the domain).
    A_lo, A_hi : float
        Interval for A at ``level``: ``A -/+ z A_err`` (Hessian) or the
        profile-likelihood interval, clipped to [0, 1].
    method : str
        ``"hessian"`` or ``"profile"``.
    flag : str or None
        Why the profile was used, or other caveats.
    nll : float
        Minimum of ``-lnL`` (without binomial coefficients).
    n_points, shots_total : int
        Number of phase points and total shots.
    converged : bool
        The optimiser met its tolerance.
    iterations : int
        Newton iterations.
    on_boundary : bool
        The MLE sits on the physical boundary ``A = 1``.
    level : float
        Coverage probability of ``[A_lo, A_hi]``.
    phases, n_even, shots : ndarray
        The data fitted (read-only).
    """

    A: float
    A_err: float
    A_err_fisher: float
    phi0: float
    phi0_err: float
    covariance: np.ndarray | None
    A_lo: float
    A_hi: float
    method: str
    flag: str | None
    nll: float
    n_points: int
    shots_total: int
    converged: bool
    iterations: int = 0
    on_boundary: bool = False
    level: float = LEVEL_1SIGMA
    hessian: np.ndarray | None = None
    phases: np.ndarray = field(default=None, repr=False)
    n_even: np.ndarray = field(default=None, repr=False)
    shots: np.ndarray = field(default=None, repr=False)

    def __post_init__(self):
        set_ = object.__setattr__
        for name in ("covariance", "hessian", "phases", "n_even", "shots"):
            set_(self, name, _readonly(getattr(self, name)))
        for name in ("A", "A_err", "A_err_fisher", "phi0", "phi0_err", "A_lo", "A_hi", "nll",
                     "level"):
            set_(self, name, float(getattr(self, name)))
        for name in ("n_points", "shots_total", "iterations"):
            set_(self, name, int(getattr(self, name)))
        set_(self, "converged", bool(self.converged))
        set_(self, "on_boundary", bool(self.on_boundary))

    @property
    def F_par(self) -> float:
        """Parity fidelity ``F_par = |A|`` (S7.2)."""
        return self.A

    def parity(self, phi):
        """Model parity ``A cos(2 phi + phi0)`` at analysis phases ``phi``."""
        return self.A * np.cos(2 * np.asarray(phi, dtype=float) + self.phi0)

    def to_dict(self) -> dict:
        """Plain-python (JSON-serialisable) copy of the fields (NaN stays NaN)."""
        out = _to_dict(self)
        out["F_par"] = self.F_par
        return out

    def report(self) -> str:
        """Readable multi-line fit report."""
        status = "converged" if self.converged else "NOT converged"
        lines = [
            "[[Parity fit]]",
            "    model              = Pi(phi) = A cos(2 phi + phi0), binomial MLE, |A| <= 1",
            f"    # phase points     = {self.n_points}",
            f"    total shots        = {self.shots_total}",
            f"    -lnL at optimum    = {self.nll:.10g}",
            f"    optimiser          = {status} after {self.iterations} Newton step(s)"
            + (" (optimum on the boundary A = 1)" if self.on_boundary else ""),
            f"    error method       = {self.method}",
            "[[Parameters]]",
            f"    A (= F_par)        = {self.A:.6f} +/- {self.A_err:.6f}"
            f"  (Fisher: {self.A_err_fisher:.6f})",
            f"    {self.level:.2%} interval = [{self.A_lo:.6f}, {self.A_hi:.6f}]",
            f"    phi0               = {self.phi0:+.6f} +/- {self.phi0_err:.6f} rad",
        ]
        if self.covariance is not None:
            c = self.covariance
            r = c[0, 1] / math.sqrt(c[0, 0] * c[1, 1])
            lines.append(f"    C(A, phi0)         = {r:+.4f}")
        if self.flag:
            lines.append(f"    flag               = {self.flag}")
        return "\n".join(lines)


class _Data:
    """Fit data: fringe angles theta = 2 phi, cos/sin, even/odd counts."""

    __slots__ = ("theta", "c", "s", "k", "m", "n", "kpos", "mpos")

    def __init__(self, phases, k, n):
        self.theta = 2.0 * phases
        self.c = np.cos(self.theta)
        self.s = np.sin(self.theta)
        self.k = k
        self.n = n
        self.m = n - k
        self.kpos = k > 0
        self.mpos = self.m > 0


def _xlog(coef, x):
    """``coef * log(x)`` with 0 for coef == 0 (any x >= 0), inf-safe."""
    with np.errstate(divide="ignore", invalid="ignore"):
        out = coef * np.log(x)
    return np.where(coef == 0, 0.0, out)


def _nll_polar(d: _Data, A, phi0):
    """-lnL at (A, phi0); arrays broadcast against the data's last axis.

    +inf outside the domain (a p_i <= 0 or >= 1 against its counts, or p_i
    outside [0, 1]).
    """
    A = np.asarray(A, dtype=float)[..., None]
    phi0 = np.asarray(phi0, dtype=float)[..., None]
    t = A * np.cos(d.theta + phi0)
    p = 0.5 * (1.0 + t)
    q = 0.5 * (1.0 - t)
    val = -(_xlog(d.k, p) + _xlog(d.m, q)).sum(axis=-1)
    bad = ((p < 0) | (q < 0)).any(axis=-1)
    return np.where(bad | np.isnan(val), np.inf, val)


def _nll_ab(d: _Data, a, b) -> float:
    """-lnL at (a, b); +inf outside the domain.  Rounding below 0 (< 1e-13) counts as 0."""
    t = a * d.c + b * d.s
    p = 0.5 * (1.0 + t)
    q = 0.5 * (1.0 - t)
    pmin, qmin = p.min(), q.min()
    if pmin > 0 and qmin > 0:
        return float(-(d.k @ np.log(p) + d.m @ np.log(q)))
    if pmin < -1e-13 or qmin < -1e-13:
        return math.inf
    p, q = np.maximum(p, 0.0), np.maximum(q, 0.0)
    val = -float(np.sum(_xlog(d.k, p)) + np.sum(_xlog(d.m, q)))
    return val if not math.isnan(val) else math.inf


def _grad_hess_ab(d: _Data, a, b):
    """Gradient and Hessian of -lnL in (a, b).

    Terms with a zero count contribute nothing also where their p is 0.
    """
    t = a * d.c + b * d.s
    p = np.maximum(0.5 * (1.0 + t), 0.0)
    q = np.maximum(0.5 * (1.0 - t), 0.0)
    if p.min() > 0 and q.min() > 0:
        kp = d.k / p
        mq = d.m / q
        ht = 0.25 * (kp / p + mq / q)             # d2(-lnL)/dt_i^2
    else:
        zero = np.zeros_like(p)
        kp = np.divide(d.k, p, out=zero.copy(), where=d.kpos)
        mq = np.divide(d.m, q, out=zero.copy(), where=d.mpos)
        ht = 0.25 * (np.divide(kp, p, out=zero.copy(), where=d.kpos)
                     + np.divide(mq, q, out=zero.copy(), where=d.mpos))
    gt = -0.5 * (kp - mq)                         # d(-lnL)/dt_i
    g = np.array([gt @ d.c, gt @ d.s])
    hc = ht * d.c
    hs = ht * d.s
    H = np.array([[hc @ d.c, hc @ d.s], [hc @ d.s, hs @ d.s]])
    return g, H


def _disk_step(x, g, H):
    """Minimiser s of the model g.s + s.H.s/2 subject to |x + s| <= 1 (H positive definite).

    The Newton step when it stays in the disk; otherwise the point y = x + s
    on the circle with (H + lam I) y = H x - g, lam > 0 (KKT of the model),
    found by Newton's method on the secular equation 1/|y(lam)| = 1.
    """
    try:
        s = -np.linalg.solve(H, g)
    except np.linalg.LinAlgError:
        s = None
    if s is not None and np.all(np.isfinite(s)):
        y = x + s
        if y @ y <= 1.0:
            return s
    h, Q = np.linalg.eigh(H)
    w = Q.T @ (H @ x - g)
    w2 = w * w
    # |y(lam)| = |w / (h + lam)| decreases from > 1 at lam = 0 to <= 1 at lam = |w| - h_min
    lam = 0.0 if h[0] > 0 else -h[0] + 1e-12 * max(abs(h[1]), 1.0)
    lo, hi = lam, max(lam, math.sqrt(float(w2.sum())) - h[0]) + 1e-300
    for _ in range(60):
        den = h + lam
        ny2 = float(np.sum(w2 / den ** 2))
        ny = math.sqrt(ny2)
        psi = 1.0 / ny - 1.0
        if psi < 0:
            lo = lam
        else:
            hi = lam
        dpsi = float(np.sum(w2 / den ** 3)) / (ny2 * ny)
        new = lam - psi / dpsi if dpsi > 0 else 0.5 * (lo + hi)
        if not lo <= new <= hi:
            new = 0.5 * (lo + hi)
        if abs(new - lam) <= 1e-15 * max(lam, 1.0) or abs(psi) < 1e-15:
            lam = new
            break
        lam = new
    y = Q @ (w / (h + lam))
    ny = math.sqrt(float(y @ y))
    if ny > 1.0:
        y = y / ny
    return y - x


def _wrap(phi):
    """Angle in (-pi, pi]."""
    w = math.remainder(phi, 2 * math.pi)
    return math.pi if w <= -math.pi else w


# --- the circle A = 1 --------------------------------------------------------
def _boundary_poles(d: _Data) -> np.ndarray:
    """Sorted phi0 values in [0, 2pi) where -lnL(A = 1, phi0) has a pole."""
    poles = np.concatenate([np.mod(math.pi - d.theta[d.kpos], 2 * math.pi),
                            np.mod(-d.theta[d.mpos], 2 * math.pi)])
    return np.unique(poles)


def _boundary_derivs(d: _Data, phi0: float):
    """d/dphi0 and d2/dphi0^2 of -lnL(A = 1, phi0) and d(-lnL)/dA at A = 1."""
    h = 0.5 * (d.theta + phi0)                    # u/2
    ch, sh = np.cos(h), np.sin(h)
    k, m = d.k, d.m
    with np.errstate(divide="ignore", invalid="ignore"):
        tk = np.where(d.kpos, k * sh / ch, 0.0)                     # k tan(u/2)
        tm = np.where(d.mpos, m * ch / sh, 0.0)                     # m cot(u/2)
        d1 = float(np.sum(tk - tm))
        d2 = float(np.sum(np.where(d.kpos, 0.5 * k / ch ** 2, 0.0)
                          + np.where(d.mpos, 0.5 * m / sh ** 2, 0.0)))
        cu = ch * ch - sh * sh                                      # cos u
        dA = float(np.sum(np.where(d.kpos, -k * cu / (2 * ch * ch), 0.0)
                          + np.where(d.mpos, m * cu / (2 * sh * sh), 0.0)))
    return d1, d2, dA


def _boundary_solve(d: _Data, phi_start: float):
    """Minimum of -lnL on the circle A = 1 in the pole-free arc containing phi_start.

    Returns ``(phi0, nll, dnll_dA)`` or None when the arc is degenerate.
    Between poles -lnL(phi0) is strictly convex and its derivative runs
    from -inf to +inf, so a bracketed Newton iteration finds the minimum.
    """
    poles = _boundary_poles(d)
    x = phi_start % (2 * math.pi)
    j = int(np.searchsorted(poles, x, side="right"))
    lo = poles[j - 1] if j > 0 else poles[-1] - 2 * math.pi
    hi = poles[j] if j < poles.size else poles[0] + 2 * math.pi
    if x <= lo or x >= hi:                        # start exactly on a pole
        x = 0.5 * (lo + hi)
    if not hi - lo > 1e-12:
        return None
    for _ in range(200):
        d1, d2, _ = _boundary_derivs(d, x)
        if d1 > 0:
            hi = min(hi, x)
        else:
            lo = max(lo, x)
        step = -d1 / d2 if d2 > 0 and np.isfinite(d1) else np.nan
        xn = x + step
        if not (lo < xn < hi):
            xn = 0.5 * (lo + hi)
        if abs(xn - x) <= 1e-13 * max(1.0, abs(x)) or hi - lo <= 1e-15:
            x = xn
            break
        x = xn
    _, _, dA = _boundary_derivs(d, x)
    return x, float(_nll_polar(d, 1.0, x)), dA


# --- the optimiser -------------------------------------------------------------
def _start(d: _Data):
    """Weighted linear least squares of the parity 2 k/n - 1 on (cos, sin)."""
    y = 2.0 * d.k / d.n - 1.0
    w = d.n
    M = np.array([[w @ (d.c * d.c), w @ (d.c * d.s)], [w @ (d.c * d.s), w @ (d.s * d.s)]])
    v = np.array([w @ (y * d.c), w @ (y * d.s)])
    a, b = np.linalg.solve(M, v)
    r = math.hypot(a, b)
    if r > 0.99:
        a, b = a * 0.99 / r, b * 0.99 / r
    elif r < 1e-3:                                # avoid the polar origin as a start
        a, b = 1e-3, 0.0
    return float(a), float(b)


def _optimise(d: _Data):
    """MLE of (a, b) on the disk a^2 + b^2 <= 1 (convex problem).

    Newton steps whose quadratic model is minimised *on the disk*
    (:func:`_disk_step`), Armijo backtracking (every trial point is feasible
    because the disk is convex; points where a p_i = 0 against its counts
    have -lnL = inf and are rejected).  Stops when the model decrease
    ``-g.s`` is below ``_NEWTON_TOL``.  An optimum on (or within 1e-9 of)
    the circle is polished by the 1-D solve on A = 1 and accepted there when
    the KKT condition ``d(-lnL)/dA <= 0`` holds.

    Returns ``(a, b, nll, converged, iterations, on_boundary)``.
    """
    a, b = _start(d)
    x = np.array([a, b])
    f = _nll_ab(d, a, b)
    converged = False
    it = 0
    for it in range(1, _MAX_NEWTON + 1):
        g, H = _grad_hess_ab(d, x[0], x[1])
        s = _disk_step(x, g, H)
        dec = float(-(g @ s))
        resolution = 64 * np.finfo(float).eps * max(1.0, abs(f))
        if not dec > max(_NEWTON_TOL, resolution):
            # the quadratic model is exact to rounding here: take the last full step
            xn = x + s
            fn = _nll_ab(d, xn[0], xn[1])
            if fn <= f + resolution:
                x, f = xn, fn
            converged = True
            break
        t = 1.0
        while True:
            xn = x + t * s
            fn = _nll_ab(d, xn[0], xn[1])
            if fn <= f - 1e-4 * t * dec:
                break
            t *= 0.5
            if t < 1e-14:
                break
        if t < 1e-14:
            converged = dec < 1e-9          # no decrease left at double precision
            break
        x, f = xn, fn
    a, b = float(x[0]), float(x[1])
    on_boundary = False
    if a * a + b * b > (1.0 - 1e-9) ** 2:
        sol = _boundary_solve(d, math.atan2(-b, a))
        if sol is not None and np.isfinite(sol[1]) and sol[1] <= f + 1e-12 * max(1.0, abs(f)) \
                and sol[2] <= 0:
            phi_b, f, _ = sol
            a, b = math.cos(phi_b), -math.sin(phi_b)
            on_boundary = True
            converged = True
    return a, b, f, converged, it, on_boundary


# --- derivatives in (A, phi0) ---------------------------------------------------
def _fd_hessian(d: _Data, A: float, phi0: float, h: float = FD_STEP):
    """Central finite-difference Hessian of -lnL in (A, phi0), step h (9 evaluations)."""
    dA = np.array([0, 1, -1, 0, 0, 1, 1, -1, -1]) * h
    dp = np.array([0, 0, 0, 1, -1, 1, -1, 1, -1]) * h
    f = _nll_polar(d, A + dA, phi0 + dp)
    if not np.all(np.isfinite(f)):
        return None
    haa = (f[1] - 2 * f[0] + f[2]) / h ** 2
    hpp = (f[3] - 2 * f[0] + f[4]) / h ** 2
    hap = (f[5] - f[6] - f[7] + f[8]) / (4 * h * h)
    return np.array([[haa, hap], [hap, hpp]])


def _information(theta, n, A, phi0):
    """Expected (Fisher) information in (A, phi0); None if some p is 0 or 1."""
    u = theta + phi0
    cu, su = np.cos(u), np.sin(u)
    pq = 0.25 * (1 - A * cu) * (1 + A * cu)       # p (1 - p)
    if np.any(pq <= 0):
        return None
    w = n / pq
    ga = 0.5 * cu                                 # dp/dA
    gp = -0.5 * A * su                            # dp/dphi0
    return np.array([[w @ (ga * ga), w @ (ga * gp)], [w @ (ga * gp), w @ (gp * gp)]])


def parity_information(phases, shots, A, phi0) -> np.ndarray:
    """Fisher information matrix in (A, phi0) of a parity scan (2 x 2).

    ``I = sum_i n_i grad(p_i) grad(p_i)^T / (p_i (1 - p_i))`` with
    ``p_i = (1 + A cos(2 phi_i + phi0)) / 2``; ``sqrt(inv(I)[0, 0])`` is the
    Cramer-Rao bound on the error of A (e.g. for planning a scan, or to
    judge a fit's ``A_err``).  Raises InputError when some ``p_i`` is 0 or 1
    (infinite information).
    """
    phases = np.atleast_1d(np.asarray(phases, dtype=float))
    n = np.broadcast_to(np.asarray(shots, dtype=float), phases.shape)
    info = _information(2 * phases, n, float(A), float(phi0))
    if info is None:
        raise InputError("some p_i is exactly 0 or 1 at these parameters: the information "
                         "is infinite")
    return info


def _phi_derivs(d: _Data, A: float, phi0: float):
    """-lnL and its first two phi0-derivatives at fixed 0 < A < 1."""
    u = d.theta + phi0
    cu, su = np.cos(u), np.sin(u)
    Acu = A * cu
    P = 1.0 + Acu
    Q = 1.0 - Acu
    if not (P.min() > 0 and Q.min() > 0):
        return math.inf, 0.0, 0.0
    f = -float(d.k @ np.log(0.5 * P) + d.m @ np.log(0.5 * Q))
    kP, mQ = d.k / P, d.m / Q
    diff = kP - mQ
    d1 = A * float(su @ diff)
    d2 = float(Acu @ diff) + A * A * float((su * su) @ (kP / P + mQ / Q))
    return f, d1, d2


def _dnll_dA(d: _Data, A: float, phi0: float) -> float:
    cu = np.cos(d.theta + phi0)
    return -float((d.k * cu) @ (1 / (1 + A * cu)) - (d.m * cu) @ (1 / (1 - A * cu)))


def _profile_at(d: _Data, A: float, phi_start: float):
    """min over phi0 of -lnL at fixed A: ``(nll, phi0, dnll/dA)``.

    Newton's method in phi0 from ``phi_start`` (the optimum's phase, or the
    previous A's), with backtracking; gradient steps where the curvature is
    not positive.  The phase converges to ~1e-9 rad (the profile value then
    is exact to ~1e-14 relative).
    """
    if A >= 1.0:
        sol = _boundary_solve(d, phi_start)
        if sol is None:
            return math.inf, phi_start, 0.0
        return sol[1], sol[0], sol[2]
    if A <= 0.0:
        return float(d.n.sum() * math.log(2.0)), phi_start, _dnll_dA(d, 0.0, phi_start)
    x = phi_start
    f, d1, d2 = _phi_derivs(d, A, x)
    for _ in range(100):
        step = -d1 / d2 if d2 > 0 else -math.copysign(0.1, d1)
        step = max(-0.5, min(0.5, step))
        if abs(step) < 1e-9:
            x += step
            break
        t = 1.0
        slack = 64 * np.finfo(float).eps * abs(f)        # rounding level of -lnL
        while True:
            fn, d1n, d2n = _phi_derivs(d, A, x + t * step)
            if fn <= f + 1e-4 * t * step * d1 + slack or t < 1e-10:
                break
            t *= 0.5
        x, f, d1, d2 = x + t * step, fn, d1n, d2n
    return f, x, _dnll_dA(d, A, x)


def _profile_root(d, target, A_in, A_out, f_out, phi_out, dfdA_out):
    """A between A_in (profile below target) and A_out (profile f_out above it).

    Safeguarded Newton from A_out (dP/dA = d(-lnL)/dA at the profiled phi0,
    envelope theorem) with bisection fallback; |dA| < 1e-10 at the end.
    """
    lo, hi = A_in, A_out                          # g < 0 at lo, g > 0 at hi
    x, phi, dfdA = A_out, phi_out, dfdA_out
    g = f_out - target
    for _ in range(100):
        if g > 0:
            hi = x
        else:
            lo = x
        xn = x - g / dfdA if dfdA != 0 and math.isfinite(dfdA) and math.isfinite(g) else math.nan
        if not (min(lo, hi) < xn < max(lo, hi)):
            xn = 0.5 * (lo + hi)
        if abs(xn - x) < 1e-10:
            x = xn
            break
        x = xn
        f, phi, dfdA = _profile_at(d, x, phi)
        g = f - target
    return float(x)


def _profile_interval(d: _Data, A_hat, phi_hat, f_min, level, scale):
    """Profile-likelihood interval of A at ``level`` (2 Delta(-lnL) <= z^2), clipped to [0, 1].

    The profile ``P(A) = min_phi0 -lnL(A, phi0)`` is non-increasing below
    the MLE and non-decreasing above it (convexity in (a, b)), so each end
    is a single crossing: bracketed by steps of 1.5, 3, 6, ... ``scale``
    from the MLE, then solved by safeguarded Newton.
    """
    target = f_min + 0.5 * _z(level) ** 2
    step0 = 1.5 * max(scale, 1e-6)
    # lower end
    if float(d.n.sum() * math.log(2.0)) <= target:      # -lnL at A = 0
        A_lo = 0.0
    else:
        step, A_in = step0, A_hat
        while True:
            trial = max(A_hat - step, 0.0)
            out = _profile_at(d, trial, phi_hat)
            if out[0] > target:
                A_lo = _profile_root(d, target, A_in, trial, *out)
                break
            A_in = trial
            step *= 2
    # upper end
    if A_hat >= 1.0:
        A_hi = 1.0
    else:
        out1 = _profile_at(d, 1.0, phi_hat)
        if not out1[0] > target:
            A_hi = 1.0
        else:
            step, A_in = step0, A_hat
            while True:
                trial = A_hat + step
                if trial >= 1.0:
                    A_hi = _profile_root(d, target, A_in, 1.0, *out1)
                    break
                out = _profile_at(d, trial, phi_hat)
                if out[0] > target:
                    A_hi = _profile_root(d, target, A_in, trial, *out)
                    break
                A_in = trial
                step *= 2
    return min(A_lo, A_hat), max(A_hi, A_hat)


def _validate_parity(phases, n_even, shots):
    phases = np.atleast_1d(np.asarray(phases, dtype=float))
    if phases.ndim != 1:
        raise InputError("phases must be one-dimensional")
    try:
        k = np.broadcast_to(np.asarray(n_even, dtype=float), phases.shape).copy()
        n = np.broadcast_to(np.asarray(shots, dtype=float), phases.shape).copy()
    except ValueError:
        raise InputError(f"phases ({phases.size}), n_even and shots must have the same "
                         "length") from None
    for name, arr in (("phase_rad", phases), ("n_even", k), ("shots", n)):
        bad = ~np.isfinite(arr)
        if bad.any():
            raise InputError(f"point {int(np.flatnonzero(bad)[0]) + 1}: {name} is not finite")
    for name, arr in (("n_even", k), ("shots", n)):
        bad = arr != np.round(arr)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"point {i + 1}: {name} = {arr[i]:g} is not an integer count")
        bad = arr < 0
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"point {i + 1}: {name} = {arr[i]:g} is negative")
    bad = n <= 0
    if bad.any():
        raise InputError(f"point {int(np.flatnonzero(bad)[0]) + 1}: shots must be > 0")
    bad = k > n
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"point {i + 1}: n_even = {k[i]:g} exceeds shots = {n[i]:g}")
    return phases, k, n


def _fringe_points(phases, tol=1e-9, period=math.pi) -> int:
    """Number of distinct phases modulo ``period`` (circular, within ``tol``).

    ``period = pi``: distinct fringe points (phi and phi + pi measure the same
    p).  ``period = pi/2``: distinct fringe *axes* (phi + pi/2 measures
    ``1 - p``, the same linear functional of (a, b)); the fit needs >= 2.
    """
    x = np.sort(np.mod(phases, period))
    if x.size == 0:
        return 0
    gaps = np.diff(np.concatenate([x, [x[0] + period]]))
    return max(int(np.sum(gaps > tol)), 1)


def fit_parity(phases, n_even, shots, level: float = LEVEL_1SIGMA) -> ParityFit:
    """Binomial MLE of a parity fringe ``Pi(phi) = A cos(2 phi + phi0)`` (S7.2).

    Parameters
    ----------
    phases : array_like, shape (m,)
        Analysis phases ``phi_i`` (rad).
    n_even : array_like of int, shape (m,)
        Even-parity counts ``k_i``.
    shots : array_like of int or int
        Shots ``n_i`` per point (may differ between points).
    level : float
        Coverage of ``[A_lo, A_hi]`` (default 1 sigma, 68.27 %).

    Returns
    -------
    ParityFit
        ``A >= 0``, ``phi0`` in (-pi, pi]; see the class and the module
        docstring for the error methods and the boundary policy.

    Raises
    ------
    InputError
        Bad counts (negative, non-integer, above shots, shots <= 0), length
        mismatch.
    FitError
        Degenerate design: all phases on the same fringe point (``2 phi``
        equal modulo 2 pi), so amplitude and phase cannot be separated.

    Examples
    --------
    >>> import numpy as np
    >>> phi = np.arange(16) * 2 * np.pi / 16
    >>> k = np.round(625 * (1 + 0.9 * np.cos(2 * phi + 0.3)) / 2)
    >>> r = fit_parity(phi, k, 625)
    >>> round(r.A, 2), round(r.phi0, 2), r.method
    (0.9, 0.3, 'hessian')
    """
    level = _check_level(level)
    phases, k, n = _validate_parity(phases, n_even, shots)
    if phases.size < 2 or _fringe_points(phases, period=math.pi / 2) < 2:
        raise FitError(
            f"degenerate parity fit: the {phases.size} point(s) all sit on one fringe axis "
            "(phases equal modulo pi/2: 2*phi equal modulo pi, where the fringe only flips "
            "sign), so the contrast A and the phase offset phi0 cannot be separated; scan the "
            "analysis phase over at least 3 distinct values that are not pi/2 apart")
    d = _Data(phases, k, n)
    a, b, f_min, converged, iterations, on_boundary = _optimise(d)
    A = 1.0 if on_boundary else min(math.hypot(a, b), 1.0)
    phi0 = _wrap(math.atan2(-b, a))
    z = _z(level)
    reasons = []

    # Fisher information at the optimum (cross-check)
    info = _information(d.theta, d.n, A, phi0)
    A_err_fisher = math.nan
    fisher_note = None
    if info is not None:
        try:
            cf = np.linalg.inv(info)
            if cf[0, 0] > 0:
                A_err_fisher = math.sqrt(cf[0, 0])
        except np.linalg.LinAlgError:
            pass
    if not np.isfinite(A_err_fisher):
        fisher_note = ("Fisher cross-check undefined (some p_i is 0 or 1 at the optimum: "
                       "infinite information)" if info is None
                       else "Fisher information singular (A = 0?)")

    # finite-difference Hessian (paper)
    Hfd = _fd_hessian(d, A, phi0)
    cov = None
    A_err_h = math.nan
    phi0_err_h = math.nan
    if Hfd is None:
        reasons.append("the finite-difference Hessian stencil (step 1e-5) leaves the domain "
                       "|A| <= 1 / 0 < p_i < 1")
    else:
        eig = np.linalg.eigvalsh(Hfd)
        if not (eig[0] > 1e-10 * abs(eig[-1]) and np.all(np.isfinite(eig))):
            reasons.append(f"Hessian not positive definite (eigenvalues {eig[0]:.3g}, "
                           f"{eig[1]:.3g})")
        else:
            cov = np.linalg.inv(Hfd)
            A_err_h = math.sqrt(cov[0, 0])
            phi0_err_h = math.sqrt(cov[1, 1])
    if on_boundary:
        reasons.insert(0, "MLE on the physical boundary A = 1")
    elif cov is not None:
        if A + BOUNDARY_SIGMAS * A_err_h >= 1.0:
            reasons.append(f"A is within {BOUNDARY_SIGMAS:g} sigma of the boundary A = 1 "
                           f"((1 - A)/sigma_Hessian = {(1 - A) / A_err_h:.2f}): the quadratic "
                           "approximation of -lnL fails there")
        elif A - BOUNDARY_SIGMAS * A_err_h <= 0.0:
            reasons.append(f"A is within {BOUNDARY_SIGMAS:g} sigma of 0 (A/sigma_Hessian = "
                           f"{A / A_err_h:.2f}): the polar quadratic approximation fails there")

    if not reasons:
        method = "hessian"
        A_err, phi0_err = A_err_h, phi0_err_h
        A_lo, A_hi = max(A - z * A_err, 0.0), min(A + z * A_err, 1.0)
    else:
        method = "profile"
        scale = next((s for s in (A_err_h, A_err_fisher) if np.isfinite(s) and s > 0),
                     0.5 / math.sqrt(d.n.sum()))
        A_lo, A_hi = _profile_interval(d, A, phi0, f_min, level, scale)
        A_err = max(A - A_lo, A_hi - A) / z
        cov = None
        if on_boundary:
            _, d2, _ = _boundary_derivs(d, phi0)
        else:
            _, _, d2 = _phi_derivs(d, A, phi0)
        phi0_err = 1.0 / math.sqrt(d2) if d2 > 0 else math.inf
        if not A_err > 0:                         # cannot happen for finite data; guard
            raise FitError("profile-likelihood interval of A has zero width")
    notes = reasons + ([fisher_note] if fisher_note else [])
    if not converged:
        notes.append("optimiser did not reach its tolerance")
    flag = "; ".join(notes) if notes else None
    if method == "profile":
        flag = (f"profile-likelihood interval ({flag})")
    return ParityFit(A=A, A_err=A_err, A_err_fisher=A_err_fisher, phi0=phi0,
                     phi0_err=phi0_err, covariance=cov, A_lo=A_lo, A_hi=A_hi, method=method,
                     flag=flag, nll=f_min, n_points=phases.size, shots_total=int(n.sum()),
                     converged=converged, iterations=iterations, on_boundary=on_boundary,
                     level=level, hessian=Hfd, phases=phases, n_even=k, shots=n)


# ==========================================================================
# combined fidelity (S7.3)
# ==========================================================================
def combined_fidelity(pop, par) -> tuple[float, float]:
    """Bell fidelity ``F = (F_pop + F_par)/2`` and ``sigma = sqrt(s_pop^2 + s_par^2)/2`` (S7.3).

    Parameters
    ----------
    pop : PopulationFidelity or (F_pop, F_pop_err)
    par : ParityFit or (F_par, F_par_err)

    Returns
    -------
    (F, F_err) : tuple of float
        The two error sources are treated as independent (S7.3).
    """
    if isinstance(pop, PopulationFidelity):
        fp, sp = pop.F_pop, pop.F_pop_err
    else:
        fp, sp = map(float, pop)
    if isinstance(par, ParityFit):
        fa, sa = par.F_par, par.A_err
    else:
        fa, sa = map(float, par)
    return 0.5 * (fp + fa), 0.5 * math.hypot(sp, sa)


# ==========================================================================
# pooling (S7.4)
# ==========================================================================
def _source(df):
    return df.attrs.get("source") if hasattr(df, "attrs") else None


def _setting_label(A, dpd) -> str:
    return f"A={float(A):g}, dpd={int(dpd)}"


def _require(df, cols, what):
    for c in cols:
        if c not in df.columns:
            raise InputError(f"{what}: required column is missing", file=_source(df), column=c)


def _check_frame(df, counts, extra_finite=()):
    """Validate a DataFrame built in Python like a file: counts, shots, dpd, finite A.

    Rows are reported as the DataFrame's position + 1 (= the data row of a
    file read by :func:`read_populations` / :func:`read_parity`).
    """
    file = _source(df)
    for c in ["A", *extra_finite]:
        arr = pd.to_numeric(df[c], errors="coerce").to_numpy(dtype=float)
        bad = ~np.isfinite(arr)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"value {df[c].iloc[i]!r} is not a finite number", file=file,
                             column=c, row=i + 1)
    _check_counts(df, [*counts, "shots"], file)
    arr = pd.to_numeric(df["dpd"], errors="coerce").to_numpy(dtype=float)
    bad = (arr != 0) & (arr != 1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"dpd = {df['dpd'].iloc[i]!r} must be 0 or 1", file=file, column="dpd",
                         row=i + 1)


def pool_populations(df: pd.DataFrame) -> pd.DataFrame:
    """Count-level pooling of population scans per setting ``(A, dpd)`` (S7.4).

    Sums ``n_even`` and ``shots`` (and ``n00``, ``n01_10``, ``n11`` when
    present; ``n_even = n00 + n11`` when only those are given) over the
    scans of each setting -- exact for any shot numbers.  Counts are
    validated as in :func:`read_populations` (rows = position + 1).

    Returns
    -------
    pandas.DataFrame
        Columns ``A, dpd, n_even, shots, n_scans`` (+ summed ``n00``,
        ``n01_10``, ``n11``), one row per setting, sorted by ``dpd`` then ``A``.
    """
    if "n_even" not in df.columns and all(c in df.columns for c in ("n00", "n01_10", "n11")):
        src_name = _source(df)
        df = df.assign(n_even=df["n00"] + df["n11"])
        df.attrs["source"] = src_name
    _require(df, ["A", "dpd", "n_even", "shots"], "populations")
    if len(df) == 0:
        raise InputError("populations table has no rows", file=_source(df))
    _check_frame(df, ["n_even"] + [c for c in ("n00", "n01_10", "n11") if c in df.columns])
    extra = [c for c in ("n00", "n01_10", "n11") if c in df.columns]
    agg = {"n_even": ("n_even", "sum"), "shots": ("shots", "sum")}
    agg.update({c: (c, "sum") for c in extra})
    if "scan" in df.columns:
        agg["n_scans"] = ("scan", "nunique")
    else:
        agg["n_scans"] = ("n_even", "size")
    out = df.groupby(["A", "dpd"], sort=True).agg(**agg).reset_index()
    for c in ["n_even", "shots", *extra, "n_scans"]:
        out[c] = out[c].astype(np.int64)
    out["dpd"] = out["dpd"].astype(np.int64)
    return out.sort_values(["dpd", "A"], kind="stable").reset_index(drop=True)


def _grid_keys(phases, grid):
    return np.floor(np.asarray(phases, dtype=float) / grid + 0.5).astype(np.int64)


def merge_parity(df: pd.DataFrame, grid: float = 0.01, near_miss: float = NEAR_MISS
                 ) -> pd.DataFrame:
    """Merge repeated parity scans at the count level (S7.4).

    Phases are rounded to a common grid (``round(phi / grid)``, default
    0.01 rad) and counts at the same grid point of the same setting
    ``(A, dpd)`` are summed.  This merged table is for tables and plots:
    :func:`gate_fidelities` fits the exact likelihood of every recorded phase
    instead, so scans whose phases jitter around a common set (each scan's
    own analysis-phase offset, recorded as is) are never refused.
    ``near_miss`` is accepted for compatibility and unused.

    Returns
    -------
    pandas.DataFrame
        ``A, dpd, phase_rad, phase_grid, n_even, shots, n_scans``:
        ``phase_grid`` is the grid point, ``phase_rad`` the shot-weighted
        mean of the merged raw phases (within ``grid/2`` of it), which is
        what :func:`gate_fidelities` fits.  Sorted by dpd, A, phase.
    """
    _require(df, ["A", "dpd", "phase_rad", "n_even", "shots"], "parity")
    if len(df) == 0:
        raise InputError("parity table has no rows", file=_source(df))
    _check_frame(df, ["n_even"], extra_finite=["phase_rad"])
    grid = float(grid)
    if not grid > 0:
        raise InputError(f"phase grid {grid:g} must be > 0")
    file = _source(df)
    work = pd.DataFrame({
        "A": df["A"].to_numpy(dtype=float), "dpd": df["dpd"].to_numpy(),
        "scan": (df["scan"].astype(str).to_numpy() if "scan" in df.columns
                 else np.full(len(df), "1")),
        "phase_rad": df["phase_rad"].to_numpy(dtype=float),
        "n_even": df["n_even"].to_numpy(dtype=float), "shots": df["shots"].to_numpy(dtype=float),
        "row": np.asarray(df.index, dtype=np.int64) + 1})
    work["key"] = _grid_keys(work["phase_rad"], grid)
    del file, near_miss
    work["wphase"] = work["phase_rad"] * work["shots"]
    out = work.groupby(["A", "dpd", "key"], sort=True).agg(
        wphase=("wphase", "sum"), n_even=("n_even", "sum"), shots=("shots", "sum"),
        n_scans=("scan", "nunique")).reset_index()
    out["phase_rad"] = out["wphase"] / out["shots"]
    out["phase_grid"] = out["key"] * grid
    out["n_even"] = out["n_even"].astype(np.int64)
    out["shots"] = out["shots"].astype(np.int64)
    out["dpd"] = out["dpd"].astype(np.int64)
    out = out[["A", "dpd", "phase_rad", "phase_grid", "n_even", "shots", "n_scans"]]
    return out.sort_values(["dpd", "A", "phase_grid"], kind="stable").reset_index(drop=True)


# ==========================================================================
# gate fidelities per setting
# ==========================================================================
def _scan_consistency(parity_df) -> dict:
    """Per setting, ``[(A_scan, A_err_scan, nll_scan, label), ...]`` from fitting each parity
    scan alone.  Scans that cannot be fitted alone (too few phases) are left out."""
    out = {}
    groups = parity_df.assign(_s=parity_df["scan"].astype(str)).groupby(["A", "dpd", "_s"])
    for (A, dpd, label), g in groups:
        try:
            r = fit_parity(g["phase_rad"].to_numpy(), g["n_even"].to_numpy(),
                           g["shots"].to_numpy())
        except (FitError, InputError):
            continue
        out.setdefault((float(A), int(dpd)), []).append((r.A, r.A_err, r.nll, label))
    return out


def _scan_lrt(raw, scan_fits, pooled_nll):
    """Likelihood-ratio test of one fringe (A, phi0) for all of a setting's scans
    against one per scan: ``(LR, dof, p)``; NaN with fewer than two fittable scans.

    Only the scans that could be fitted alone enter both sides (the pooled fit is
    repeated on them when some were left out)."""
    if len(scan_fits) < 2:
        return math.nan, 0, math.nan
    nll_sep = sum(f[2] for f in scan_fits)
    lr = max(2.0 * (pooled_nll - nll_sep), 0.0)
    dof = 2 * (len(scan_fits) - 1)
    return float(lr), dof, float(stats.chi2.sf(lr, dof))


def gate_fidelities(populations_df: pd.DataFrame, parity_df: pd.DataFrame,
                    interval: str = "wilson", grid: float = 0.01) -> pd.DataFrame:
    """Bell-state fidelity per setting ``(A, dpd)`` from raw counts (S7.1-S7.4).

    Pools the population scans (:func:`pool_populations`), merges the parity
    scans on the common phase grid (:func:`merge_parity`), fits the merged
    fringe (:func:`fit_parity`) and combines (:func:`combined_fidelity`).

    Parameters
    ----------
    populations_df, parity_df : pandas.DataFrame
        As returned by :func:`read_populations` / :func:`read_parity` (or
        any frame with their columns).
    interval : {"wilson", "clopper-pearson"}
        Interval method of the population fidelity.

    Returns
    -------
    pandas.DataFrame
        One row per setting, sorted by dpd then A, columns
        :data:`GATE_COLUMNS` (``A, dpd, F_pop, F_pop_err, F_par, F_par_err,
        F, F_err, contrast, phi0, n_scans, shots, interval_method``) then
        ``F_pop_lo, F_pop_hi, F_par_lo, F_par_hi, parity_method,
        parity_flag, A_err_fisher, phi0_err, parity_shots, n_phases,
        n_scans_pop, n_scans_par, parity_converged, parity_scan_chi2,
        parity_scan_dof, parity_scan_p``.  ``shots`` is the pooled
        population shots; ``n_scans`` the number of distinct scan labels of
        the setting in either table.

    Notes
    -----
    Count-level pooling (S7.4) assumes every scan measures the same fringe.
    ``parity_scan_chi2 = sum_s (A_s - A)^2 / A_err_s^2`` over the scans
    fitted alone (``dof`` = scans - 1, ``parity_scan_p`` its chi-square
    p-value; NaN with a single scan) tests that: a small p means the
    contrast varies between scans (drift) by more than shot noise, and the
    pooled ``F_par_err`` (shot noise only) then understates the error of the
    setting's mean contrast.  It is reported, not applied.

    Raises
    ------
    InputError
        A setting present in one table but not the other, bad columns, phase
        grid mismatch, fewer than 3 distinct phases in a setting.
    """
    method = _interval_name(interval)
    pop = pool_populations(populations_df)
    par = merge_parity(parity_df, grid=grid)
    pop_keys = {(float(a), int(d)) for a, d in zip(pop["A"], pop["dpd"])}
    par_keys = {(float(a), int(d)) for a, d in zip(par["A"], par["dpd"])}
    missing = sorted(pop_keys - par_keys)
    if missing:
        raise InputError(f"setting {_setting_label(*missing[0])} has populations but no parity "
                         "scans (a Bell fidelity needs both)", file=_source(parity_df))
    missing = sorted(par_keys - pop_keys)
    if missing:
        raise InputError(f"setting {_setting_label(*missing[0])} has parity scans but no "
                         "populations (a Bell fidelity needs both)",
                         file=_source(populations_df))

    def scans(df):
        if "scan" not in df.columns:
            return {}
        g = df.assign(_s=df["scan"].astype(str)).groupby(["A", "dpd"])["_s"]
        return {(float(a), int(d)): set(v) for (a, d), v in g}

    pop_scans, par_scans = scans(populations_df), scans(parity_df)
    per_scan = _scan_consistency(parity_df) if "scan" in parity_df.columns else {}
    par_groups = {(float(a), int(d)): g for (a, d), g in par.groupby(["A", "dpd"])}
    # the fit uses every recorded phase of every scan (exact likelihood), not the
    # merged grid: scans whose phases jitter around a common set are pooled exactly
    raw = pd.DataFrame({"A": parity_df["A"].to_numpy(dtype=float),
                        "dpd": parity_df["dpd"].to_numpy().astype(np.int64),
                        "phase_rad": parity_df["phase_rad"].to_numpy(dtype=float),
                        "n_even": parity_df["n_even"].to_numpy(dtype=float),
                        "shots": parity_df["shots"].to_numpy(dtype=float),
                        "_s": (parity_df["scan"].astype(str).to_numpy()
                               if "scan" in parity_df.columns else "1")})
    raw_groups = {(float(a), int(d)): g for (a, d), g in raw.groupby(["A", "dpd"])}
    rows = []
    for rec in pop.itertuples(index=False):
        key = (float(rec.A), int(rec.dpd))
        pf = population_fidelity(rec.n_even, rec.shots, interval=method)
        g = par_groups[key]
        r = raw_groups[key]
        if _fringe_points(r["phase_rad"].to_numpy(), tol=grid / 2) < 3:
            raise InputError(f"setting {_setting_label(*key)} has fewer than 3 distinct "
                             "analysis phases (modulo pi); a fringe fit needs at least 3",
                             file=_source(parity_df), column="phase_rad")
        try:
            fit = fit_parity(r["phase_rad"].to_numpy(), r["n_even"].to_numpy(),
                             r["shots"].to_numpy())
        except FitError as exc:
            raise FitError(f"setting {_setting_label(*key)}: {exc}") from None
        F, F_err = combined_fidelity(pf, fit)
        sp, sq = pop_scans.get(key, set()), par_scans.get(key, set())
        scan_A = per_scan.get(key, [])
        if len(scan_A) >= 2:
            chi2 = float(sum((f[0] - fit.A) ** 2 / f[1] ** 2 for f in scan_A))
            dof = len(scan_A) - 1
            p_scan = float(stats.chi2.sf(chi2, dof))
        else:
            chi2, dof, p_scan = math.nan, 0, math.nan
        pooled_nll = fit.nll
        fitted_alone = len(scan_A)
        if 2 <= fitted_alone < r["_s"].nunique():
            # some scans could not be fitted alone: pool only the others for the test
            keep = r[r["_s"].isin([f[3] for f in scan_A])]
            pooled_nll = fit_parity(keep["phase_rad"].to_numpy(), keep["n_even"].to_numpy(),
                                    keep["shots"].to_numpy()).nll
        lr, lr_dof, lr_p = _scan_lrt(r, scan_A, pooled_nll)
        if lr_p < SCAN_CONSISTENCY_ALPHA:
            src = _source(parity_df)
            log.warning("%ssetting %s: its %d parity scans do not share one fringe "
                        "(likelihood ratio %.1f for %d dof, p = %.2g): pooled F_par_err "
                        "understates the scatter", f"{src}: " if src else "",
                        _setting_label(*key), fitted_alone, lr, lr_dof, lr_p)
        rows.append({
            "A": key[0], "dpd": key[1], "F_pop": pf.F_pop, "F_pop_err": pf.F_pop_err,
            "F_par": fit.F_par, "F_par_err": fit.A_err, "F": F, "F_err": F_err,
            "contrast": fit.A, "phi0": fit.phi0,
            "n_scans": len(sp | sq) if (sp or sq) else int(rec.n_scans),
            "shots": int(rec.shots), "interval_method": method,
            "F_pop_lo": pf.lo, "F_pop_hi": pf.hi, "F_par_lo": fit.A_lo, "F_par_hi": fit.A_hi,
            "parity_method": fit.method, "parity_flag": fit.flag,
            "A_err_fisher": fit.A_err_fisher, "phi0_err": fit.phi0_err,
            "parity_shots": fit.shots_total, "n_phases": fit.n_points,
            "n_scans_pop": len(sp) if sp else int(rec.n_scans),
            "n_scans_par": len(sq) if sq else int(g["n_scans"].max()),
            "parity_converged": fit.converged,
            "parity_scan_chi2": chi2, "parity_scan_dof": dof, "parity_scan_p": p_scan,
            "parity_scan_lr": lr, "parity_scan_lr_dof": lr_dof, "parity_scan_lr_p": lr_p,
        })
    out = pd.DataFrame(rows)
    return out.sort_values(["dpd", "A"], kind="stable").reset_index(drop=True)


# ==========================================================================
# readers
# ==========================================================================
def _check_counts(df, cols, file):
    """Integer, non-negative counts; shots > 0; counts <= shots."""
    vals = {c: pd.to_numeric(df[c], errors="coerce").to_numpy(dtype=float) for c in cols}
    for c in cols:
        arr = vals[c]
        bad = ~(arr == np.round(arr))                 # also NaN and non-numbers
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"count {df[c].iloc[i]!r} is not an integer", file=file, column=c,
                             row=i + 1)
        bad = arr < 0
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"count {arr[i]:g} is negative", file=file, column=c, row=i + 1)
    shots = vals["shots"]
    bad = shots <= 0
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"shots = {shots[i]:g}: a setting with no shots (shots must be > 0)",
                         file=file, column="shots", row=i + 1)
    for c in cols:
        if c == "shots":
            continue
        bad = vals[c] > shots
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"count {vals[c][i]:g} exceeds shots = {shots[i]:g}", file=file,
                             column=c, row=i + 1)


def _check_dpd(df, file):
    arr = df["dpd"].to_numpy(dtype=float)
    bad = (arr != 0) & (arr != 1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"dpd = {arr[i]:g} must be 0 or 1", file=file, column="dpd", row=i + 1)
    df["dpd"] = arr.astype(np.int64)


def _check_scan(df, file):
    empty = df["scan"] == ""
    if empty.any():
        i = int(np.flatnonzero(empty.to_numpy())[0])
        raise InputError("scan label is empty", file=file, column="scan", row=i + 1)


def _check_unique(df, keys, file, what):
    dup = df.duplicated(keys, keep=False)
    if dup.any():
        idx = np.flatnonzero(dup.to_numpy())
        first = df.iloc[idx[0]]
        same = [int(i) + 1 for i in idx if all(df.iloc[i][k] == first[k] for k in keys)]
        label = ", ".join(f"{k}={first[k]}" for k in keys)
        raise InputError(f"{what} {label} appears in more than one row (rows "
                         f"{', '.join(map(str, same[:6]))}): a duplicated line?",
                         file=file, column=keys[-1], row=same[1])


def _header(path) -> list[str]:
    """Column names of a CSV file ([] if it cannot be read; read_table reports why)."""
    try:
        cols = pd.read_csv(path, comment="#", skipinitialspace=True, nrows=0).columns
    except Exception:  # noqa: BLE001 - read_table gives the proper message
        return []
    return [str(c).strip() for c in cols]


def read_populations(path: str | os.PathLike) -> pd.DataFrame:
    """Read and validate a population file.

    Columns ``A, dpd, scan, n_even, shots`` or ``A, dpd, scan, n00, n01_10,
    n11, shots`` (then ``n_even = n00 + n11`` and ``n00 + n01_10 + n11 ==
    shots`` is required; with both forms present ``n_even`` must equal
    ``n00 + n11``).  Extra columns allowed, ``#`` lines are comments.

    Bad input raises InputError naming file, column and row: counts not
    integer, negative or above ``shots``; ``shots <= 0``; ``dpd`` not 0/1;
    ``A`` outside [0, 1]; the same ``(A, dpd, scan)`` in two rows.

    Returns
    -------
    pandas.DataFrame
        Numeric columns as float64 (``dpd`` int, ``scan`` str), ``n_even``
        always present; the index is the 0-based data row.
    """
    name = str(path)
    optional = ["n_even", "n00", "n01_10", "n11"]
    present = _header(path)
    base = read_table(path, ["A", "dpd", "scan", "shots"], optional,
                      numeric=["A", "dpd", "shots"] + [c for c in optional if c in present],
                      ranges={"A": (0.0, 1.0)})
    trio = [c for c in ("n00", "n01_10", "n11") if c in base.columns]
    if "n_even" not in base.columns and len(trio) < 3:
        missing = next(c for c in ("n00", "n01_10", "n11") if c not in base.columns)
        raise InputError("required column is missing (give n_even, or n00, n01_10 and n11)",
                         file=name, column=missing if trio else "n_even")
    df = base
    _check_dpd(df, name)
    _check_scan(df, name)
    counts = (["n_even"] if "n_even" in df.columns else []) + (trio if len(trio) == 3 else [])
    _check_counts(df, counts + ["shots"], name)
    if len(trio) == 3:
        tot = df["n00"] + df["n01_10"] + df["n11"]
        bad = (tot != df["shots"]).to_numpy()
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"n00 + n01_10 + n11 = {tot.iloc[i]:g} differs from shots = "
                             f"{df['shots'].iloc[i]:g}", file=name, column="shots", row=i + 1)
        even = df["n00"] + df["n11"]
        if "n_even" in df.columns:
            bad = (even != df["n_even"]).to_numpy()
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                raise InputError(f"n_even = {df['n_even'].iloc[i]:g} differs from n00 + n11 = "
                                 f"{even.iloc[i]:g}", file=name, column="n_even", row=i + 1)
        else:
            df["n_even"] = even
    _check_unique(df, ["A", "dpd", "scan"], name, "population setting")
    df.attrs["source"] = name
    return df


def read_parity(path: str | os.PathLike, grid: float = 0.01) -> pd.DataFrame:
    """Read and validate a parity-fringe file ``A, dpd, scan, phase_rad, n_even, shots``.

    Bad input raises InputError naming file, column and row: counts not
    integer, negative or above ``shots``; ``shots <= 0``; ``dpd`` not 0/1;
    ``A`` outside [0, 1]; the same phase grid point twice in one scan; a
    setting with fewer than 3 distinct analysis phases (modulo pi, since
    ``phi`` and ``phi + pi`` measure the same fringe point); scans of a
    setting off the common phase grid (see :func:`merge_parity`).

    Returns
    -------
    pandas.DataFrame
        As read (``dpd`` int, ``scan`` str); the index is the 0-based data row.
    """
    name = str(path)
    df = read_table(path, ["A", "dpd", "scan", "phase_rad", "n_even", "shots"],
                    numeric=["A", "dpd", "phase_rad", "n_even", "shots"],
                    ranges={"A": (0.0, 1.0)})
    _check_dpd(df, name)
    _check_scan(df, name)
    _check_counts(df, ["n_even", "shots"], name)
    key = pd.Series(_grid_keys(df["phase_rad"], grid), index=df.index, name="_key")
    cols = [df["A"], df["dpd"], df["scan"], key]
    dup = pd.concat(cols, axis=1).duplicated(keep=False)
    if dup.any():
        idx = np.flatnonzero(dup.to_numpy())
        ref = (df["A"].iloc[idx[0]], df["dpd"].iloc[idx[0]], df["scan"].iloc[idx[0]],
               key.iloc[idx[0]])
        same = [int(i) + 1 for i in idx
                if (df["A"].iloc[i], df["dpd"].iloc[i], df["scan"].iloc[i], key.iloc[i]) == ref]
        raise InputError(
            f"setting {_setting_label(ref[0], ref[1])}, scan {ref[2]}: phase "
            f"{df['phase_rad'].iloc[idx[0]]:.6g} rad appears twice (rows {same[0]} and "
            f"{same[1]}, same {grid:g}-rad grid point): a duplicated line?", file=name,
            column="phase_rad", row=same[1])
    for (A, dpd), g in df.groupby(["A", "dpd"], sort=False):
        if _fringe_points(g["phase_rad"].to_numpy(), tol=grid / 2) < 3:
            ph = np.unique(np.round(np.mod(g["phase_rad"].to_numpy(), math.pi), 6))
            raise InputError(
                f"setting {_setting_label(A, dpd)} has only {ph.size} distinct analysis "
                f"phase(s) modulo pi ({', '.join(f'{p:g}' for p in ph[:5])}); a parity "
                "fringe fit needs at least 3", file=name, column="phase_rad",
                row=int(g.index[0]) + 1)
        if _fringe_points(g["phase_rad"].to_numpy(), tol=grid / 2, period=math.pi / 2) < 2:
            raise InputError(
                f"setting {_setting_label(A, dpd)}: all analysis phases are equal modulo "
                "pi/2 (one fringe axis: 2*phi equal modulo pi), so contrast and phase offset "
                "cannot be separated; a degenerate fringe fit", file=name,
                column="phase_rad", row=int(g.index[0]) + 1)
    merge_parity(df, grid=grid)                   # grid consistency (raises with file/row)
    df.attrs["source"] = name
    return df
