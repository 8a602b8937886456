"""Size of the engine's state, checked against the memory limit before it is made.

The engine integrates the master equation for a density matrix of
``(spin states x n_fock)^2`` amplitudes, or the Schrodinger equation for
``spin states x n_fock x thermal levels`` (:mod:`dpdfit.models.gate_sim.integrators`).
``n_fock`` follows the displacement bound ``B`` (drive strength times duration,
:mod:`dpdfit.models.gate_sim.fock`), the thermal levels follow ``nbar``: a gate
rate in the wrong unit (with ``eta Omega0`` calibrated to it) or a time scan
thousands of gate times long makes ``B`` and so the state grow without bound
(a rate stored in Hz but labelled kHz needed 4 x 17950 Fock levels, a
38 GiB array).  :func:`engine_size` computes the dimensions without
allocating anything, :func:`check_engine_size` refuses a state whose
estimated peak (:data:`~dpdfit.core.memory.ENGINE_BYTES_PER_AMPLITUDE` per
amplitude) is above the memory limit with one
:class:`~dpdfit.errors.InputError` line.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from dpdfit.core.memory import ENGINE_BYTES_PER_AMPLITUDE, check_memory

from .arguments import check_times, positive
from .fock import displacement_bound, fock_cutoff, thermal_levels

__all__ = ["EngineSize", "engine_size", "check_engine_size", "setting_size"]


@dataclasses.dataclass(frozen=True)
class EngineSize:
    """Dimensions of one engine integration (:func:`engine_size`)."""

    #: spin states (4 for two ions, 2 for one)
    spin_states: int
    #: Fock levels of the mode
    n_fock: int
    #: thermal levels of the initial state (the Schrodinger equation's columns)
    n_thermal: int
    #: master equation (density matrix) rather than Schrodinger columns
    lindblad: bool
    #: displacement bound (zero-point amplitudes) behind ``n_fock``
    B: float
    #: longest integrated time [s] and tone spacing [Hz]
    t_max: float
    xi0: float

    @property
    def amplitudes(self) -> float:
        """Complex amplitudes of the integrated state."""
        dn = float(self.spin_states) * float(self.n_fock)
        return dn * dn if self.lindblad else dn * float(self.n_thermal)

    @property
    def nbytes(self) -> float:
        """Estimated peak memory of the integration (bytes)."""
        return self.amplitudes * ENGINE_BYTES_PER_AMPLITUDE

    def describe(self) -> str:
        """``"master equation on 4 spin states x 17950 Fock levels"`` (for messages)."""
        if self.lindblad:
            return f"master equation on {self.spin_states} spin states x {self.n_fock} Fock levels"
        return (f"Schrodinger equation on {self.spin_states} spin states x {self.n_fock} Fock "
                f"levels x {self.n_thermal} thermal levels")

    def cause(self) -> str:
        """Why the state is that large, and the likely slip (for messages)."""
        return (f"the drive displaces the mode by up to {self.B:.3g} zero-point amplitudes "
                f"within {self.t_max * 1e6:.4g} us at a tone spacing xi0 = "
                f"{self.xi0 / 1e3:.4g} kHz with {self.n_thermal} thermal levels: a gate rate, "
                "a time or nbar in the wrong unit?")


def engine_size(b, c, n, eta_Omega0, xi0, t_max, nbar, *, n_ions=2, lindblad=True,
                n_fock=None, fock_tol=None) -> EngineSize:
    """The dimensions :func:`~dpdfit.models.gate_sim.evolve.evolve` (``lindblad=False``) or
    :func:`~dpdfit.models.gate_sim.evolve.evolve_lindblad` starts with for times up to
    ``t_max`` [s]; arguments as theirs.  Nothing is allocated."""
    tail = {} if fock_tol is None else {"tail": fock_tol}
    t_max = float(check_times(t_max))
    B = displacement_bound(b, c, n, eta_Omega0, xi0, max(t_max, 1e-300), n_ions)
    if n_fock is not None:
        N = int(n_fock)
    else:
        N = fock_cutoff(nbar, B, **({} if fock_tol is None else {"tol": fock_tol}), **tail)
    return EngineSize(spin_states=2 ** n_ions, n_fock=N, n_thermal=thermal_levels(nbar, **tail),
                      lindblad=bool(lindblad), B=float(B), t_max=t_max, xi0=float(xi0))


def check_engine_size(size: EngineSize, what: str | None = None, *, file: str | None = None,
                      hint: str | None = None, at_once: int = 1) -> None:
    """InputError (one line) if ``at_once`` integrations of ``size`` would not fit in memory
    (:func:`~dpdfit.core.memory.check_memory`); ``what`` and ``hint`` default to the
    state's description and :meth:`EngineSize.cause`."""
    check_memory(size.nbytes * at_once, what or f"the gate simulation ({size.describe()})",
                 file=file, hint=size.cause() if hint is None else hint)


def setting_size(b, c, n, eta_Omega0, xi0, *, nbar, T2=np.inf, ndot=0.0, scan_times=None,
                 power_error_db=0.0, n_fock=None, fock_tol=None, T2_corr=np.inf,
                 **_ignored) -> EngineSize:
    """The largest integration of :func:`~dpdfit.models.gate_sim.setting.setting_branches`
    with the same arguments (the two-ion branch at the gate time and the scan times)."""
    eO = positive("eta_Omega0", eta_Omega0) * 10 ** (float(power_error_db) / 20)
    T = 1.0 / positive("xi0", xi0)
    scan = np.zeros(0) if scan_times is None else np.atleast_1d(check_times(scan_times))
    lind = not (np.isinf(float(T2)) and float(ndot) == 0 and np.isinf(float(T2_corr)))
    return engine_size(b, c, n, eO, xi0, max([T, *scan.tolist()]), nbar, n_ions=2,
                       lindblad=lind, n_fock=n_fock, fock_tol=fock_tol)
