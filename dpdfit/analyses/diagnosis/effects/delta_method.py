"""Errors of an effect's sizes by the delta method.

A small numerical helper of :class:`~dpdfit.analyses.diagnosis.effects.base.Effect`
(:meth:`~dpdfit.analyses.diagnosis.effects.base.Effect.sizes`), kept apart so that the
base class reads as the list of what an effect declares and does.
"""

from __future__ import annotations

import numpy as np

__all__ = ["delta_method_errors"]


def delta_method_errors(values_at, p: dict, cov, free: list, scales: list) -> dict:
    """``{size: (value, 1-sigma error)}`` of the sizes ``values_at(p)`` gives
    (``{size: (value, unit, meaning)}``): numerical gradient over the fitted parameters
    ``free`` (central steps of ``1e-4`` x their ``scales``), covariance ``cov`` in their
    order; NaN errors without a finite covariance or gradient."""
    base = values_at(p)
    grads = {k: np.zeros(len(free)) for k in base}
    if cov is not None and len(free):
        for i, (name, s) in enumerate(zip(free, scales)):
            h = 1e-4 * s
            up = values_at({**p, name: p[name] + h})
            dn = values_at({**p, name: p[name] - h})
            for k in base:
                grads[k][i] = (up[k][0] - dn[k][0]) / (2 * h)
    out = {}
    for k, (val, _, _) in base.items():
        err = float("nan")
        g = grads[k]
        if (cov is not None and len(free) and np.all(np.isfinite(cov))
                and np.all(np.isfinite(g))):
            err = float(np.sqrt(max(g @ cov @ g, 0.0)))
        out[k] = (float(val), err)
    return out

