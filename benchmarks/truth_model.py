"""The transfer function of the simulated truth AOM, in the polynomial form dpdfit fits.

Used by ``alignment_coverage.py`` (the sweep its gate points are drawn around) and by
the tests (``from benchmarks.truth_model import truth_poly_tf``).  A benchmark
module, not a test module, so that the benchmarks need nothing from ``tests/``.
"""

import numpy as np

from dpdfit.models.transfer import TransferFunction
from dpdfit.simulation.aom_truth import BraggAOM


def truth_poly_tf(K=8, with_phase=True):
    """Transfer function whose polynomials approximate the physical AOM closely."""
    aom = BraggAOM()
    A = np.linspace(0, 1, 400)
    V = A[:, None] ** np.arange(1, K + 1)
    a, *_ = np.linalg.lstsq(V, aom.y(A), rcond=None)
    a = a / a[0]
    if with_phase:
        b, *_ = np.linalg.lstsq(V[:, :5], aom.phase(A), rcond=None)
        return TransferFunction(range(1, K + 1), a, range(1, 6), b)
    return TransferFunction(range(1, K + 1), a)
