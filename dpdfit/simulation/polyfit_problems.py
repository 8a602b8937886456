"""Two ill-conditioned least-squares problems and their 50-digit reference solution.

Synthetic data with a known answer, as the rest of this layer: the problems
``benchmarks/polyfit_precision.py`` measures :func:`dpdfit.fits.polyfit.polyfit` on and
``tests/fits/test_polyfit.py`` checks it with.  The reference needs mpmath (in the
``test`` extra), imported when it is called.
"""

from __future__ import annotations

import numpy as np

__all__ = ["mp_reference", "hard_case", "no_constant_case"]


def mp_reference(x, y, powers, sigma=None, dps=50):
    """Weighted LS by normal equations in mpmath (exact conversion of the doubles).

    cond(A)**2 ~ 1e30 < 1e50, so 50 digits leave ~20 correct ones.  Applies
    the same sigma convention as polyfit.  Returns mpf lists/matrices.
    """
    import mpmath    # an optional dependency (the test extra), not an import circle

    with mpmath.workdps(dps):
        n, p = len(x), len(powers)
        w = [mpmath.mpf(1) if sigma is None else 1 / mpmath.mpf(float(s)) for s in
             (sigma if sigma is not None else [None] * n)]
        A = mpmath.matrix(n, p)
        b = mpmath.matrix(n, 1)
        for i in range(n):
            xi = mpmath.mpf(float(x[i]))
            for j, k in enumerate(powers):
                A[i, j] = w[i] * xi ** k
            b[i] = w[i] * mpmath.mpf(float(y[i]))
        ninv = mpmath.inverse(A.T * A)
        coef = ninv * (A.T * b)
        res = b - A * coef
        chi2 = mpmath.fsum(res[i] ** 2 for i in range(n))
        dof = n - p
        scale = 1 if sigma is not None else chi2 / dof
        stderr = [mpmath.sqrt(scale * ninv[j, j]) for j in range(p)]
        return {
            "coefficients": [coef[j] for j in range(p)],
            "stderr": stderr,
            "chi2": chi2,
            "residual_std": mpmath.sqrt(chi2 / dof) if dof > 0 else None,
            "cov": ninv * scale,
        }


def hard_case(with_sigma):
    """Degree 10 with constant on [-9, -3]: raw Vandermonde cond ~ 1e15."""
    rng = np.random.default_rng(20240611)
    x = np.linspace(-9.0, -3.0, 60)
    y = np.exp(x / 3) * np.sin(x) + 0.01 * rng.standard_normal(x.size)
    sigma = 0.01 * (1 + rng.uniform(size=x.size)) if with_sigma else None
    return x, y, tuple(range(11)), sigma


def no_constant_case(with_sigma):
    """Powers 1..8 on [0, 1], a compressive curve plus noise."""
    rng = np.random.default_rng(7)
    x = np.linspace(0.0, 1.0, 60)
    y = np.tanh(1.7 * x) / np.tanh(1.7) + 0.005 * rng.standard_normal(x.size)
    sigma = 0.005 * (0.5 + rng.uniform(size=x.size)) if with_sigma else None
    return x, y, tuple(range(1, 9)), sigma
