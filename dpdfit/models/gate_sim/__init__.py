"""Physics engine of simulated two-ion entangling-gate experiments.

Turns an optical tone spectrum (complex tone amplitudes on the red and blue
motional sidebands, e.g. from the physical AOM model with intermodulation,
AM-to-PM conversion and red/blue asymmetry) plus experimental parameters into
outcome probabilities of the gate experiment, and draws counts from them.
Nothing here uses the closed-form phase-space estimator of
:mod:`dpdfit.models.fidelity`: the spin-motion dynamics are integrated by brute
force, decoherence is applied physically (Lindblad master equation), and the
state-preparation and detection errors are applied as the physical branches
and the classical confusion matrix they are.

System and conventions
----------------------
Two 88Sr+ ions (optical qubit ``|0> = S_1/2`` ground state, ``|1> = D_5/2``),
one motional mode (stretch mode, frequency ``nu``), Lamb-Dicke parameter
``eta`` (0.026 in the experiment; only the product ``eta * Omega0`` enters).
Spin basis ``|00>, |01>, |10>, |11>`` (``sigma_z`` eigenstates, ion 1 most
significant, ``|0> = (1, 0)^T``); ``sigma+ = |1><0|`` (absorption raises
``S -> D``), ``sigma- = |0><1|``.

Modules (each documents the method it implements)
-------------------------------------------------
``drive``        optical field convention, Hamiltonian, tone amplitudes, ``xi0`` calibration
``fock``         thermal initial state, Fock-space cutoff
``size``         the state's dimensions and memory, checked before an integration
``integrators``  Schrodinger and Lindblad equations, DOP853 step loop; decoherence model
``compiled_lindblad``  the master equation's DOP853 integration compiled (numba)
``dephasing``    slow dephasing: a time profile during the gate, decay of the final coherences
``evolve``       :func:`evolve`, :func:`evolve_lindblad`: reduced spin states at given times
``states``       analysis pulse, outcome/parity probabilities, Bell fidelities, gate target
``spam``         preparation branches and their mixing, detection confusion
``setting``      measured probabilities of one setting (:func:`simulate_setting`)
``results``      :class:`SettingProbabilities`, :class:`SampledCounts`
``arguments``    the argument checks the modules share (InputError on bad input)
"""

from .dephasing import accumulated_dephasing, dephase_coherences
from .drive import ETA, calibrate_xi0, field_amplitudes
from .evolve import evolve, evolve_lindblad
from .integrators import KERNELS, load_compiled_kernel
from .fock import THERMAL_TAIL, displacement_bound, fock_cutoff, thermal_levels, thermal_weights
from .results import SampledCounts, SettingProbabilities
from .size import EngineSize, check_engine_size, engine_size, setting_size
from .setting import (NDOT, P_DET, P_PREP, T2_S, parity_even, populations, setting_branches,
                      simulate_setting)
from .spam import confusion, mix_branches
from .states import (BELL_TARGET, analysis_rotation, bell_fidelity_max, gate_target,
                     outcome_probabilities, parity_outcomes, state_bell_fidelity)

__all__ = [
    "BELL_TARGET", "ETA", "THERMAL_TAIL", "T2_S", "NDOT", "P_PREP", "P_DET",
    "field_amplitudes", "thermal_weights", "displacement_bound", "fock_cutoff", "calibrate_xi0",
    "evolve", "evolve_lindblad", "analysis_rotation", "outcome_probabilities",
    "parity_outcomes", "confusion", "state_bell_fidelity", "bell_fidelity_max", "gate_target",
    "populations", "parity_even", "SettingProbabilities", "SampledCounts", "simulate_setting",
    "mix_branches", "setting_branches", "thermal_levels", "EngineSize", "engine_size",
    "check_engine_size", "setting_size", "accumulated_dephasing", "dephase_coherences",
    "KERNELS", "load_compiled_kernel",
]
