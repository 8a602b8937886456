"""Population fidelity ``F_pop = n_even / shots`` with binomial intervals (Supplement S7.1).

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
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from dpdfit.core.display import Displayable
from dpdfit.errors import InputError

from .levels import LEVEL_1SIGMA, check_level, normal_quantile

__all__ = ["PopulationFidelity", "population_fidelity", "interval_method"]


@dataclass(frozen=True, repr=False)
class PopulationFidelity(Displayable):
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
        return super().to_dict()

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
        z = normal_quantile(level)
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


def interval_method(interval: str) -> str:
    """The binomial interval method ``"wilson"`` or ``"clopper-pearson"`` named by ``interval``
    (case, ``_`` and spaces aside; ``"cp"`` and ``"exact"`` mean Clopper-Pearson)."""
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
    method = interval_method(interval)
    level = check_level(level)
    F = k / n
    err = math.sqrt(F * (1 - F) / n)
    lo, hi = _binomial_interval(k, n, level, method)
    flag = None
    if k in (0, n):
        flag = (f"n_even = {k} of {n}: the binomial sigma sqrt(F(1-F)/N) is 0; "
                f"use the {method} interval [{float(lo):.6g}, {float(hi):.6g}]")
    return PopulationFidelity(F_pop=float(F), F_pop_err=float(err), lo=float(lo), hi=float(hi),
                              interval_method=method, level=level, n_even=k, shots=n, flag=flag)
