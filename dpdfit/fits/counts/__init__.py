"""Raw-count inference of Bell-state fidelities (Supplement S7).

From the raw counts of a Bell-state experiment -- a population measurement
(even-parity outcomes ``n_even = n00 + n11`` of ``shots``) and parity-fringe
scans (even-parity counts ``k_i`` of ``n_i`` shots at analysis phases
``phi_i``) -- this package computes the population fidelity ``F_pop`` (S7.1),
the parity contrast ``F_par = A`` by binomial maximum likelihood (S7.2), the
combined fidelity (S7.3), and pools repeated scans at the count level (S7.4),
with error bars that stay honest near ``F = 1``.

The parts, in the order of the supplement:

``population``
    ``F_pop`` and its binomial intervals (Wilson, Clopper-Pearson; S7.1).
``parity_likelihood``, ``parity_optimiser``
    The binomial likelihood of a parity fringe and its MLE on ``|A| <= 1`` (S7.2).
``parity_intervals``
    Errors of the contrast: finite-difference Hessian, Fisher cross-check,
    profile likelihood near the boundaries (S7.2).
``parity_fit``
    :class:`ParityFit` and :func:`fit_parity` (S7.2).
``pooling``
    Count-level pooling of repeated scans (S7.4).
``gates``
    :func:`combined_fidelity` (S7.3) and the per-setting table
    :func:`gate_fidelities` (S7.1-S7.4).

The readers of the count files are :func:`dpdfit.recordings.counts.read_populations`
and :func:`dpdfit.recordings.counts.read_parity`.
"""

from .gates import GATE_COLUMNS, combined_fidelity, gate_fidelities
from .levels import LEVEL_1SIGMA
from .parity_fit import ParityFit, fit_parity
from .parity_intervals import BOUNDARY_SIGMAS, HESSIAN_FD_STEP, parity_information
from .pooling import merge_parity, pool_populations
from .population import PopulationFidelity, population_fidelity

__all__ = [
    "LEVEL_1SIGMA", "HESSIAN_FD_STEP", "BOUNDARY_SIGMAS", "PopulationFidelity",
    "population_fidelity", "ParityFit", "fit_parity", "parity_information", "combined_fidelity",
    "pool_populations", "merge_parity", "gate_fidelities", "GATE_COLUMNS",
]
