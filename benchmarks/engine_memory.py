#!/usr/bin/env python
"""Peak memory per element of the gate engine's state and of the deviation search.

    python benchmarks/engine_memory.py

The source of two estimates in ``dpdfit/core/memory.py``:

* ``ENGINE_BYTES_PER_AMPLITUDE`` -- traced peak (``tracemalloc``, which sees
  numpy's buffers) of one master-equation integration divided by its
  ``(4 n_fock)^2`` density-matrix amplitudes, and of one Schrodinger
  integration divided by its ``4 n_fock M`` amplitudes (``M`` thermal levels),
  at forced ``n_fock`` = 30 to 200 (measured: 561 and ~500 B, flat in n_fock);
* ``SCAN_BYTES_PER_INTERVAL`` -- traced peak of the deviation search of ``n``
  points divided by its ``n (n + 1) / 2`` intervals (measured: 81 B).
"""

import tracemalloc

import numpy as np

from dpdfit.analyses.diagnosis.evidence.deviations import deviating_intervals
from dpdfit.models import gate_sim


def _peak(fn) -> int:
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def main():
    b = c = np.array([0.5, 0.5])
    n = np.array([1, 2])
    xi0 = 3.4e3
    eO = xi0 / gate_sim.calibrate_xi0(b, c, n, 1.0)
    m = gate_sim.thermal_weights(0.1).size
    print("n_fock  master eq. B/amplitude  Schrodinger B/amplitude")
    for N in (30, 60, 120, 200):
        lind = _peak(lambda: gate_sim.evolve_lindblad(b, c, n, eO, xi0, [1 / xi0], 0.1, T2=0.05,
                                                      ndot=5.0, n_fock=N, rtol=1e-4, atol=1e-6))
        pure = _peak(lambda: gate_sim.evolve(b, c, n, eO, xi0, [1 / xi0], 0.1, n_fock=N))
        print(f"{N:6d}  {lind / (4 * N) ** 2:22.0f}  {pure / (4 * N * m):23.0f}")
    print("points  deviation search B/interval")
    rng = np.random.default_rng(1)
    for k in (500, 1000, 2000):
        peak = _peak(lambda: deviating_intervals(np.arange(k, dtype=float), rng.normal(size=k)))
        print(f"{k:6d}  {peak / (k * (k + 1) / 2):24.0f}")


if __name__ == "__main__":
    main()
