"""Vectorised double-double ("dd") arithmetic on numpy arrays.

A double-double number is an unevaluated sum ``hi + lo`` of two IEEE doubles
with ``|lo| <= ulp(hi) / 2``; it carries about 106 significant bits
(~32 decimal digits).  Here a dd array is a plain tuple ``(hi, lo)`` of two
float64 arrays of the same (broadcastable) shape, so every operation below is
an element-wise numpy expression and works on arrays of any shape.

Why this is hand-written
------------------------
:mod:`dpdfit.fits.polyfit` needs the least-squares residuals of ill-conditioned
polynomial designs (condition numbers up to ~1e15) in more than double
precision, thousands of times (coverage simulations), at numpy speed:

* numpy has no portable extended-precision type: ``np.longdouble`` is the
  80-bit x87 format (64-bit mantissa, ~19 digits) only on x86 Linux/macOS, is
  plain float64 on MSVC and ARM64 macOS, and even where it is 80 bits it is
  too short for residuals at condition number 1e15;
* mpmath is arbitrary precision but pure Python, i.e. ~1000x slower than a
  vectorised numpy expression -- fine for a reference solution in a test, far
  too slow for the fitter itself.

The error-free transformations are the classical ones (Knuth's TwoSum,
Dekker's FastTwoSum, Dekker/Veltkamp splitting with 2**27 + 1 = 134217729 for
TwoProd), see e.g. Hida, Li & Bailey, "Library for double-double and
quad-double arithmetic" (2007), and Muller et al., "Handbook of floating-point
arithmetic", ch. 4.  They require round-to-nearest binary64 arithmetic without
extended intermediates (true for numpy on every supported platform) and no
overflow: the Dekker split computes ``134217729 * a``, so ``|a|`` must stay
below ~1e300 (``max_split_abs``); products whose error term underflows
(``|a * b| < ~1e-290``) are no longer exact.  The fitter scales its columns
and right-hand side by powers of two to magnitudes ~1, far from both limits.

The relative error of one :func:`dd_add` / :func:`dd_mul` / :func:`dd_div_d`
is a small multiple of 2**-104 ~ 5e-32; :func:`dd_sum` uses the cheaper
"sloppy" addition, whose *absolute* error bound is what a summation needs.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "SPLITTER", "max_split_abs",
    "two_sum", "fast_two_sum", "split", "two_prod",
    "dd", "dd_add", "dd_sub", "dd_add_d", "dd_mul",
    "dd_mul_d", "dd_div_d", "dd_sum", "dd_dot", "dd_to_float",
]

#: Dekker/Veltkamp splitting constant 2**27 + 1.
SPLITTER = 134217729.0
#: Largest magnitude that :func:`split` handles without overflow.
max_split_abs = np.finfo(np.float64).max / SPLITTER


# --------------------------------------------------------------------------
# error-free transformations on doubles
# --------------------------------------------------------------------------
def two_sum(a, b):
    """Return ``(s, e)`` with ``s = fl(a + b)`` and ``s + e == a + b`` exactly."""
    s = a + b
    bb = s - a
    e = (a - (s - bb)) + (b - bb)
    return s, e


def fast_two_sum(a, b):
    """Like :func:`two_sum`, valid when ``|a| >= |b|`` (or ``a == 0``)."""
    s = a + b
    e = b - (s - a)
    return s, e


def split(a):
    """Split ``a`` into ``(hi, lo)``, ``a == hi + lo``, each fitting 26 bits."""
    t = SPLITTER * a
    hi = t - (t - a)
    return hi, a - hi


def two_prod(a, b):
    """Return ``(p, e)`` with ``p = fl(a * b)`` and ``p + e == a * b`` exactly."""
    p = a * b
    ah, al = split(a)
    bh, bl = split(b)
    e = ((ah * bh - p) + ah * bl + al * bh) + al * bl
    return p, e


# --------------------------------------------------------------------------
# double-double operations; a dd value is a tuple (hi, lo)
# --------------------------------------------------------------------------
def dd(hi, lo=None):
    """Make a dd array from float64 data (``lo`` defaults to zeros)."""
    hi = np.asarray(hi, dtype=np.float64)
    lo = np.zeros_like(hi) if lo is None else np.asarray(lo, dtype=np.float64)
    return hi, lo


def dd_add(a, b):
    """``a + b`` for dd ``a``, ``b`` (accurate IEEE-style addition)."""
    s, e = two_sum(a[0], b[0])
    t, f = two_sum(a[1], b[1])
    e = e + t
    s, e = fast_two_sum(s, e)
    e = e + f
    return fast_two_sum(s, e)


def dd_sub(a, b):
    """``a - b`` for dd ``a``, ``b``."""
    return dd_add(a, (-b[0], -b[1]))


def dd_add_d(a, d):
    """``a + d`` for dd ``a`` and double ``d``."""
    s, e = two_sum(a[0], d)
    e = e + a[1]
    return fast_two_sum(s, e)


def dd_mul(a, b):
    """``a * b`` for dd ``a``, ``b``."""
    p, e = two_prod(a[0], b[0])
    e = e + (a[0] * b[1] + a[1] * b[0])
    return fast_two_sum(p, e)


def dd_mul_d(a, d):
    """``a * d`` for dd ``a`` and double ``d``."""
    p, e = two_prod(a[0], d)
    e = e + a[1] * d
    return fast_two_sum(p, e)


def dd_div_d(a, d):
    """``a / d`` for dd ``a`` and double ``d`` (``d`` non-zero)."""
    q1 = a[0] / d
    p, e = two_prod(q1, d)
    s, f = two_sum(a[0], -p)
    f = f - e
    f = f + a[1]
    q2 = (s + f) / d
    return fast_two_sum(q1, q2)


def _add_for_sum(a0, a1, b0, b1):
    """Sloppy dd addition used inside :func:`dd_sum`.

    ``|error| <= ~2 * 2**-106 * (|a| + |b|)``: the same absolute bound per
    addition that a summation error analysis uses anyway, at half the cost of
    :func:`dd_add` (whose extra work only buys a *relative* bound for a single
    addition under cancellation).
    """
    s, e = two_sum(a0, b0)
    e += a1
    e += b1
    return fast_two_sum(s, e)


def dd_sum(a, axis=0):
    """Sum a dd array over ``axis`` by pairwise (tree) reduction in dd.

    Every level of the tree adds the first half of the remaining slots to the
    second half in one vectorised dd addition (an odd slot left over is
    carried to the next level), so the cost is ``ceil(log2(n))`` array
    operations and the absolute rounding error is at most about
    ``2 * log2(n) * 2**-106 * sum(|a|)``.

    Parameters
    ----------
    a : tuple of ndarray
        dd array ``(hi, lo)``; ``lo`` may be any array broadcastable to ``hi``.
    axis : int
        Axis to reduce.

    Returns
    -------
    tuple of ndarray
        dd array with ``axis`` removed.
    """
    hi = np.asarray(a[0], dtype=np.float64)
    lo = np.broadcast_to(np.asarray(a[1], dtype=np.float64), hi.shape)
    axis = axis % hi.ndim if hi.ndim else 0
    lead = (slice(None),) * axis
    n = hi.shape[axis]
    if n == 0:
        z = np.zeros(hi.shape[:axis] + hi.shape[axis + 1:])
        return z, z.copy()
    while n > 1:
        h = n // 2
        first, second = lead + (slice(0, h),), lead + (slice(h, 2 * h),)
        s_hi, s_lo = _add_for_sum(hi[first], lo[first], hi[second], lo[second])
        if n % 2:
            rest = lead + (slice(2 * h, n),)
            s_hi = np.concatenate([s_hi, hi[rest]], axis=axis)
            s_lo = np.concatenate([s_lo, lo[rest]], axis=axis)
        hi, lo, n = s_hi, s_lo, h + n % 2
    return hi[lead + (0,)], lo[lead + (0,)]


def dd_to_float(a):
    """Round a dd array to the nearest double (``hi + lo``)."""
    return a[0] + a[1]


def dd_dot(a, b, axis=0):
    """Accurate dot product / weighted sum ``sum(a * b)`` over ``axis`` in dd.

    ``a`` and ``b`` are dd arrays (tuples) that broadcast against each other;
    the element-wise products are formed in dd and reduced pairwise with
    :func:`dd_sum`.
    """
    return dd_sum(dd_mul(a, b), axis=axis)
