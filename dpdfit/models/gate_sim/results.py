"""Results of one gate setting: outcome probabilities and the counts sampled from them."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dpdfit.errors import InputError

__all__ = ["SampledCounts", "SettingProbabilities"]


@dataclass(frozen=True)
class SampledCounts:
    """Counts drawn from a :class:`SettingProbabilities`.

    Attributes
    ----------
    pop_counts : ndarray of int, shape (3,)
        Numbers of ``00, 01+10, 11`` outcomes in ``shots_pop`` shots at the gate time.
    parity_counts : ndarray of int, shape (n_phases, 3)
        ``00, 01+10, 11`` counts per analysis phase (``shots_par`` shots each).
    scan_counts : ndarray of int, shape (n_times, 3) or None
    """

    pop_counts: np.ndarray
    parity_counts: np.ndarray
    scan_counts: np.ndarray | None = None
    shots_pop: int = 0
    shots_par: int = 0
    shots_scan: int = 0

    @property
    def even_counts(self) -> np.ndarray:
        """Number of even-parity outcomes per phase."""
        return self.parity_counts[:, 0] + self.parity_counts[:, 2]

    def __getitem__(self, key):
        """Mapping access: ``n00``, ``n01_10``, ``n11`` (population measurement),
        ``parity_even`` (even counts per phase), ``parity_counts``, ``scan_counts``."""
        table = {"n00": lambda: int(self.pop_counts[0]), "n01_10": lambda: int(self.pop_counts[1]),
                 "n11": lambda: int(self.pop_counts[2]), "parity_even": lambda: self.even_counts,
                 "parity_counts": lambda: self.parity_counts,
                 "scan_counts": lambda: self.scan_counts}
        if key not in table:
            raise KeyError(key)
        return table[key]()


@dataclass(frozen=True)
class SettingProbabilities:
    """Outcome probabilities of one experimental setting (see
    :func:`dpdfit.models.gate_sim.setting.simulate_setting`).

    Attributes
    ----------
    xi0, T_gate, eta_Omega0 : float
        Tone spacing [Hz], gate time ``1/xi0`` [s], ``eta Omega0`` used [rad/s]
        (including any power error).
    pop : ndarray, shape (3,)
        Measured ``(P00, P01+P10, P11)`` at ``T_gate`` (all imperfections).
    parity_phases : ndarray, shape (K,)
        Analysis phases [rad].
    parity_probs : ndarray, shape (K, 3)
        ``(P00, P01+P10, P11)`` after the analysis pulse (all imperfections).
    scan_times : ndarray (S,) or None
        Time-scan times [s]; ``scan_pop`` (S, 3) the measured populations.
    rho_gate : ndarray (4, 4)
        Two-ion spin state at ``T_gate`` with dephasing and heating, ideal
        preparation (the physical gate output).
    fidelity : float
        ``<BELL_TARGET|rho_gate|BELL_TARGET>``: the exact Bell fidelity w.r.t.
        the ideal target of the ideal (symmetric real, calibrated) tone set,
        ``(|00> + i|11>)/sqrt2``.  Sensitive to a common spin-phase rotation
        (e.g. a common AM/PM phase of the gate tones).
    fidelity_max : float
        ``max_chi`` of the fidelity with ``(|00> + e^{i chi}|11>)/sqrt2``
        (``(P00+P11)/2 + |rho_{00,11}|``), what a parity scan with a free
        fringe phase measures (no SPAM).
    fidelity_gate : float
        Fidelity with :func:`~dpdfit.models.gate_sim.states.gate_target` of
        the setting's own gate tones (IM-free, calibrated, no decoherence): the loss caused by the
        intermodulation tones, power/rate errors and decoherence, i.e. what
        the spectral estimate of :mod:`dpdfit.models.fidelity` predicts.
    params : dict
        The settings (nbar, T2, ndot, p_prep, p_det, power_error_db, ...).
    info : dict
        Numerical diagnostics (Fock cutoff, top-level population, RHS calls).
    """

    xi0: float
    T_gate: float
    eta_Omega0: float
    pop: np.ndarray
    parity_phases: np.ndarray
    parity_probs: np.ndarray
    rho_gate: np.ndarray
    fidelity: float
    fidelity_max: float
    fidelity_gate: float
    scan_times: np.ndarray | None = None
    scan_pop: np.ndarray | None = None
    params: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def time_scan(self) -> np.ndarray | None:
        """Alias of ``scan_pop``."""
        return self.scan_pop

    @property
    def P_even(self) -> np.ndarray:
        """``P00 + P11`` after the analysis pulse, per phase."""
        return self.parity_probs[:, 0] + self.parity_probs[:, 2]

    @property
    def parity(self) -> np.ndarray:
        """``Pi(phi) = 2 P_even - 1``."""
        return 2 * self.P_even - 1

    def parity_fit(self):
        """Exact least-squares fit ``Pi = a0 + a1 cos phi + b1 sin phi + C cos(2 phi + phi0)``.

        Returns ``(C, phi0, a0)`` (``C >= 0``).  Exact (noise-free) when the
        phases determine the five harmonics, e.g. 16 equally spaced phases.
        """
        ph = self.parity_phases
        A = np.stack([np.ones_like(ph), np.cos(ph), np.sin(ph), np.cos(2 * ph),
                      np.sin(2 * ph)], axis=1)
        coef, *_ = np.linalg.lstsq(A, self.parity, rcond=None)
        C = float(np.hypot(coef[3], coef[4]))
        # C cos(2 phi + phi0) = C cos(phi0) cos(2 phi) - C sin(phi0) sin(2 phi)
        phi0 = float(np.arctan2(-coef[4], coef[3]))
        return C, phi0, float(coef[0])

    @property
    def apparent_fidelity(self) -> float:
        """``(P00 + P11)/2 + C/2`` from the measured (SPAM-affected) probabilities."""
        return float(0.5 * (self.pop[0] + self.pop[2]) + 0.5 * self.parity_fit()[0])

    def sample(self, rng: np.random.Generator, shots_pop: int, shots_par: int,
               shots_scan: int | None = None) -> SampledCounts:
        """Draw counts: multinomial ``(00, 01+10, 11)`` per measurement.

        Parameters
        ----------
        rng : numpy.random.Generator
        shots_pop : int
            Shots of the population measurement at the gate time.
        shots_par : int
            Shots per analysis phase.
        shots_scan : int, optional
            Shots per time-scan point (requires ``scan_times``).
        """
        def norm(p):
            p = np.clip(np.asarray(p, dtype=float), 0.0, None)
            return p / p.sum(axis=-1, keepdims=True)

        for name, v in (("shots_pop", shots_pop), ("shots_par", shots_par)):
            if int(v) != v or v < 0:
                raise InputError(f"{name} must be a non-negative integer, got {v}")
        pop = rng.multinomial(int(shots_pop), norm(self.pop))
        par = rng.multinomial(int(shots_par), norm(self.parity_probs))
        scan = None
        if shots_scan is not None:
            if self.scan_pop is None:
                raise InputError("no time scan was simulated (scan_times=None)")
            if int(shots_scan) != shots_scan or shots_scan < 0:
                raise InputError(f"shots_scan must be a non-negative integer, got {shots_scan}")
            scan = rng.multinomial(int(shots_scan), norm(self.scan_pop))
        return SampledCounts(pop_counts=pop, parity_counts=par, scan_counts=scan,
                             shots_pop=int(shots_pop), shots_par=int(shots_par),
                             shots_scan=int(shots_scan or 0))
