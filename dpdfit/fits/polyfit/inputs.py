"""Inputs of :func:`~dpdfit.fits.polyfit.polyfit`: the power specification and the data checks.

:func:`parse_powers` reads a textual power list (``"0:10"``, ``"1,2,5"``),
:func:`check_powers` validates any iterable of powers, :func:`validate_inputs`
checks ``x``, ``y``, ``sigma`` and the powers together (InputError for bad
values, FitError for too few points or distinct abscissae).
"""

from __future__ import annotations

import operator
import re
from collections.abc import Iterable

import numpy as np

from dpdfit.errors import FitError, InputError

__all__ = ["parse_powers", "check_powers", "format_powers", "validate_inputs"]

_SPEC_RANGE = re.compile(r"^\s*(\d+)\s*:\s*(\d+)\s*$")


def parse_powers(spec: str) -> tuple[int, ...]:
    """Parse a textual power specification.

    Parameters
    ----------
    spec : str
        Either an inclusive range ``"lo:hi"`` (``"0:10"`` -> 0, 1, ..., 10) or
        a comma-separated list of non-negative integers (``"1,2,5"``).

    Returns
    -------
    tuple of int
        The distinct powers, ascending.

    Raises
    ------
    InputError
        Empty, negative, duplicated, reversed-range or non-integer specs.
    """
    if not isinstance(spec, str):
        raise InputError(f"power spec must be a string like '0:10' or '1,2,5', got {spec!r}")
    text = spec.strip()
    if not text:
        raise InputError("power spec is empty; use e.g. '0:10' or '1,2,5'")
    match = _SPEC_RANGE.match(text)
    if match:
        lo, hi = int(match.group(1)), int(match.group(2))
        if hi < lo:
            raise InputError(f"power range '{spec}' is empty (end {hi} < start {lo})")
        return tuple(range(lo, hi + 1))
    if ":" in text:
        raise InputError(f"bad power range '{spec}': expected 'lo:hi' with integers 0 <= lo <= hi")
    items = [item.strip() for item in text.split(",")]
    powers = []
    for item in items:
        if not re.fullmatch(r"[+-]?\d+", item):
            raise InputError(f"bad power '{item}' in power spec '{spec}': expected a "
                             "non-negative integer")
        powers.append(int(item))
    return check_powers(powers)


def check_powers(powers: Iterable) -> tuple[int, ...]:
    """Validate an iterable of powers; return them distinct and ascending."""
    if isinstance(powers, str):
        return parse_powers(powers)
    try:
        items = list(powers)
    except TypeError:
        raise InputError(f"powers must be an iterable of non-negative integers, "
                         f"got {powers!r}") from None
    out = []
    for item in items:
        if isinstance(item, (bool, np.bool_)):
            raise InputError(f"power {item!r} is not an integer")
        try:
            k = operator.index(item)
        except TypeError:
            raise InputError(f"power {item!r} is not an integer") from None
        if k < 0:
            raise InputError(f"power {k} is negative; powers must be >= 0")
        out.append(int(k))
    if not out:
        raise InputError("no powers given; need at least one power, e.g. 0:3")
    if len(set(out)) != len(out):
        dup = sorted({k for k in out if out.count(k) > 1})
        raise InputError(f"duplicate power(s) {', '.join(map(str, dup))} in powers")
    return tuple(sorted(out))


def format_powers(powers) -> str:
    """``"0..10"`` for a run of consecutive powers, else ``"1, 2, 5"``."""
    if len(powers) > 2 and list(powers) == list(range(powers[0], powers[-1] + 1)):
        return f"{powers[0]}..{powers[-1]}"
    return ", ".join(map(str, powers))


def _as_1d(name: str, values) -> np.ndarray:
    """``values`` as a finite 1-D float64 array, or InputError."""
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be numeric") from None
    if arr.ndim != 1:
        raise InputError(f"{name} must be 1-D, got shape {arr.shape}")
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        raise InputError(f"{name} has {bad.size} non-finite value(s) "
                         f"(first at index {bad[0]}: {arr[bad[0]]})")
    return arr


def validate_inputs(x, y, sigma, powers):
    """Checked ``x, y, sigma (or None), powers``."""
    powers = check_powers(powers)
    x = _as_1d("x", x)
    y = _as_1d("y", y)
    if x.size != y.size:
        raise InputError(f"x and y differ in length ({x.size} vs {y.size})")
    if sigma is not None:
        if np.ndim(sigma) == 0:              # one sigma for every point
            try:
                sigma = np.full(x.size, sigma, dtype=np.float64)
            except (TypeError, ValueError):
                raise InputError(f"sigma must be numeric, got {sigma!r}") from None
        sigma = _as_1d("sigma", sigma)
        if sigma.size != x.size:
            raise InputError(f"sigma and x differ in length ({sigma.size} vs {x.size})")
        bad = np.flatnonzero(sigma <= 0)
        if bad.size:
            raise InputError(f"sigma must be > 0; {bad.size} value(s) are not "
                             f"(first at index {bad[0]}: {sigma[bad[0]]})")
    n, p = x.size, len(powers)
    if sigma is None and n <= p:
        raise FitError(f"{n} points for {p} coefficients: without sigma the noise is "
                       f"estimated from the residuals, which needs more than {p} points")
    if n < p:
        raise FitError(f"{n} points for {p} coefficients: need at least {p}")
    n_distinct = np.unique(x).size
    if n_distinct < p:
        raise FitError(f"only {n_distinct} distinct x value(s) for {p} coefficients: "
                       f"the design matrix is rank deficient")
    return x, y, sigma, powers

