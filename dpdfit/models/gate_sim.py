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

*Optical field.*  The positive-frequency part of the field at the ions is ::

    E(t) = sum_k E_k exp(-i (omega_L + 2 pi f_k) t),   omega_L = qubit frequency,

with a *blue* tone ``f_k = +(nu + n xi0)`` of complex amplitude ``E_k = b_n``
and a *red* tone ``f_k = -(nu + n xi0)`` of amplitude ``E_k = c_n`` (``n``
any integer: ``n = 0`` is a resonant IM3 tone, negative ``n`` allowed).
Amplitudes are in units of the normalised field amplitude; ``Omega0``
[rad/s] is the carrier Rabi frequency of one tone of unit amplitude.

*Relation to dpdfit.models.spectrum.*  :func:`dpdfit.models.spectrum.field_tone_powers`
returns Fourier coefficients ``y_k`` of the complex envelope
``y(t) = sum_k y_k exp(+i 2 pi f_k t)`` (engineering convention; the tone
at ``+f`` is the blue one, i.e. the optical field is ``Re[y(t) e^{+i omega_L t}]``).
Its positive-frequency part is ``(1/2) sum_k conj(y_k) e^{-i(omega_L + 2 pi f_k) t}``,
so ``b = conj(blue)``, ``c = conj(red)`` (the factor 1/2 is absorbed in
``Omega0``); use :func:`field_amplitudes`.  For real spectra the two
conventions coincide; for complex ones conjugating all amplitudes changes the
dynamics (it mirrors the phase-space trajectories), so the conversion matters.

*Hamiltonian.*  Interaction picture w.r.t. qubit (``omega_L = omega_0``) and
mode, ``e^{i k x} ~ 1 + i eta (a e^{-i nu t} + a^dag e^{i nu t})`` (first
order Lamb-Dicke), rotating-wave approximation, the carrier (off resonant by
``nu``) and the opposite-sideband terms (off resonant by ``2 nu``) dropped.
A blue tone then keeps ``i eta b_n sigma+ a^dag e^{-i delta_n t}``, a red one
``i eta c_n sigma+ a e^{+i delta_n t}``, ``delta_n = 2 pi n xi0``::

    H(t)/hbar = (eta Omega0 / 2) sum_{j=1,2} sum_n [ i sigma+_j ( b_n a^dag e^{-i delta_n t}
                                                     + c_n a e^{+i delta_n t} ) + h.c. ]
              = sum_j [ K_j(t) a^dag + K_j(t)^dag a ],
    K(t) = (eta Omega0/2) i [ beta(t) sigma+ - gamma(t) sigma- ],
    beta(t) = sum_n b_n e^{-i delta_n t},   gamma(t) = sum_n conj(c_n) e^{-i delta_n t}.

For ``b_n = c_n = r_n`` real, ``K = (eta Omega0/2) beta(t) sigma_y`` and ::

    H = S_y (f(t) a^dag + f(t)^* a),   S_y = sigma_y1 + sigma_y2,
    f(t) = (eta Omega0/2) sum_n r_n e^{-i delta_n t}.

``tests/exact_ms.py`` integrates ``S_x (f' a^dag + h.c.)`` with
``f' = (eta Omega/2) sum_n r_n e^{+i(delta_n t + phi_n)}``: exact_ms writes
the force rotating as ``e^{+i delta t}`` (its detuning has the opposite
sign).  With the spin-axis rotation ``W = exp(-i pi/4 (sigma_z1 + sigma_z2))``
(``W S_x W^dag = S_y``) the two agree exactly (tested to < 1e-9) as ::

    rho_here(n, b = r e^{-i phi}, c = r e^{+i phi})
        = W rho_exact_ms(-n, r, -phi) W^dag          (mirror n -> -n)
        = W conj(rho_exact_ms(n, r, phi)) W^dag       (antiunitary: complex
                                                      conjugation + motional parity)

A fixed spin-axis rotation alone is *not* enough: without ``n -> -n`` (or the
conjugation) the geometric phase has the opposite sign at all times.  Both
maps preserve the Bell fidelity with the respective targets.  So a phase
``phi_n`` of exact_ms and of :mod:`dpdfit.models.fidelity` is a *motional* phase:
opposite phases on the two sidebands, ``b_n = r_n e^{-i phi_n}``,
``c_n = r_n e^{+i phi_n}``.  Equal phases ``b_n = c_n = |r_n| e^{i theta_n}``
(what a symmetric AM/PM distortion of the envelope produces) instead rotate
the *spin* axis of tone pair ``n`` by ``theta_n`` (a common ``theta`` rotates
the Bell phase by ``2 theta``); unequal ``theta_n`` make the forces of
different tones non-commuting, which no closed form covers and which this
engine integrates exactly.

For the symmetric real Cardioid(1,2) (``r = [+1, -1]/sqrt(1.5)``) with the
calibration of :func:`calibrate_xi0` the gate at ``T = 1/xi0`` is
``U = exp(-i (pi/8) S_y^2)``: ``|00> -> (|00> + i|11>)/sqrt(2)`` (:data:`BELL_TARGET`).

Numerics
--------
Dimensionless time ``tau = t xi0`` (the gate ends at ``tau = 1``); the state
lives in spin (x) truncated Fock space.  The Schrodinger equation
(:func:`propagate`) is integrated for all thermal Fock initial states at once
(columns of one matrix ODE), the Lindblad equation
(:func:`propagate_lindblad`) for the full density matrix (dimension
``(4 n_fock)^2``, ~ 1e4 complex numbers at ``nbar = 0.1``), both with
``scipy.integrate.DOP853`` stepped by hand; requested times are read from
each step's dense output and reduced to the spin density matrix at once.

* Thermal state ``p_m = nbar^m/(1+nbar)^{m+1}``, truncated at
  ``m_max`` where the neglected tail ``(nbar/(1+nbar))^{m_max+1} < 1e-10``,
  renormalised.
* Fock cutoff (``n_fock=None``): a bound ``B`` on the spin-dependent
  displacement from the triangle inequality,
  ``B = 2 (eta Omega0/2) max(sum_n |b_n| w_n, sum_n |c_n| w_n)``,
  ``w_n = min(2/|delta_n|, t_max)`` (``2`` ions; ``1`` for one ion), and the
  smallest ``n_fock`` for which the displaced thermal state
  ``sum_m p_m D(B)|m><m|D(B)^dag`` (computed numerically) puts less than
  1e-14 of population on the levels ``>= n_fock - 1``.  The population of the
  top level is monitored along the whole integration; if it exceeds 1e-12
  (possible for strongly non-commuting drives, where ``B`` is only the
  first-order displacement) ``n_fock`` is enlarged and the run repeated.
  The tests check that ``n_fock + 10`` changes the result by < 1e-11.
* Integration error at the default tolerances (``rtol=1e-9, atol=1e-11``),
  against ``rtol=1e-11``: ~2e-12 in rho for the Schrodinger equation, ~4e-10
  for the master equation.
* Cost (2-core development machine, 8 tones per sideband, ``nbar = 0.1``,
  ``xi0 = 3.4 kHz``): :func:`propagate` ~50 ms (``n_fock = 27``), two-ion
  master equation ~0.21 s, one-ion ~0.03 s, :func:`simulate_setting` with
  the defaults ~0.25 s (+0.08 s for a 41-point time scan); ``nbar = 1``
  ~1.2 s.

Decoherence and imperfections
-----------------------------
* **Qubit dephasing** (coherence time ``T2`` [s], default 50 ms): Markovian
  ``sigma_z`` noise on each ion *during* the gate, Lindblad operators
  ``L_j = sqrt(1/(2 T2)) sigma_z^(j)``, so a single-ion coherence decays as
  ``exp(-t/T2)``.  Included exactly in the master equation.
* **Motional heating** (rate ``ndot`` [quanta/s], default 5 /s = 0.005
  quanta/ms): ``L_+ = sqrt(ndot) a^dag``, ``L_- = sqrt(ndot) a`` (heating
  towards infinite temperature, ``d<n>/dt = ndot``).  Exact in the master
  equation (the truncated dissipator stays trace preserving).

  Validation (tests): against first-order (Dyson) perturbation theory built
  from the analytic ``alpha(t)``, ``theta(t)`` of the ideal gate, in which a
  ``sigma_z`` jump at ``t`` acts as ``D(-2 alpha Y_j) exp(4 i theta Y_j Y_k) Z_j``
  and a heating jump as the spin-dependent kick ``a + alpha S_y``.  For the
  Cardioid(1,2) gate (``nbar = 0.1``) the first-order losses are: contrast
  ``T/T2``, Bell fidelity ``0.591 T/T2`` (0.581 at ``nbar = 0``; applying
  the dephasing channel at the end of the gate instead would give ``T/T2``,
  1.7x too much), heating ``4 ndot int_0^T |alpha|^2 dt = 3.7e-4`` at
  5 quanta/s and ``T = 294 us``.  The master equation agrees within the
  second-order remainder (``<= 2 (T/T2)^2``; measured ``0.29 (T/T2)^2 = 1e-5``
  at ``T2 = 50 ms``; heating ~ loss^2 = 1.4e-7).
* **State preparation** (``p_prep`` per ion, default 0.003): with
  probability ``p_prep`` an ion is pumped into the other Zeeman sublevel of
  S1/2; it is driven neither by the gate nor by the analysis pulse and reads
  bright (``|0>``).  The four branches are computed exactly: both ions good
  ``(1-p)^2`` (two-ion dynamics), one ion out ``2 p (1-p)`` (the other ion is
  propagated alone under the same drive, dephasing and heating: single-spin
  dynamics), both out ``p^2`` (both bright).
* **Detection** (``p_det`` per ion, default 5e-5): each ion's bright/dark
  result is flipped with probability ``p_det``, independently: confusion
  matrix ``C (x) C``, ``C = [[1-p, p], [p, 1-p]]`` on the four outcomes.

Measurements
------------
* Populations at time ``t``: ``P00, P01+P10, P11`` (two, one, zero bright
  ions; ``|0>`` bright).
* Parity analysis: after the gate an ideal, instantaneous global pi/2 pulse
  ``R(phi) = exp(-i pi/4 (cos phi X + sin phi Y))`` on each (good) ion, then
  measurement; ``P_even(phi) = P00 + P11``, ``Pi(phi) = 2 P_even - 1``.  For
  :data:`BELL_TARGET`, ``Pi(phi) = cos(2 phi + phi0)`` with ``phi0 = pi/2``,
  i.e. ``Pi = -sin(2 phi)``.  The contrast of a general state is
  ``2 |rho_{00,11}|``.  A branch with one ion out contributes terms at
  ``phi`` (not ``2 phi``), so fits should include them.
* Bell fidelities of the two-ion state after the gate (dephasing and
  heating included, preparation and detection not): ``fidelity`` w.r.t. the
  fixed :data:`BELL_TARGET` (ideal target of the ideal tone set; sensitive to
  the Bell-phase rotation caused by a common phase or a red/blue imbalance of
  the gate tones), ``fidelity_max`` (best Bell phase: what populations plus a
  free-phase parity fringe measure) and ``fidelity_gate`` (w.r.t. the state
  the setting's own gate tones produce without IM tones, errors or
  decoherence: :func:`gate_target`).
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import DOP853
from scipy.linalg import expm

from dpdfit.errors import InputError

__all__ = [
    "BELL_TARGET", "ETA", "THERMAL_TAIL", "field_amplitudes", "thermal_weights",
    "displacement_bound", "fock_cutoff", "calibrate_xi0", "propagate", "propagate_lindblad",
    "analysis_rotation", "outcome_probabilities", "parity_outcomes", "confusion",
    "bell_fidelity", "bell_fidelity_max", "gate_target", "populations", "parity_even",
    "SettingProbabilities", "SampledCounts", "simulate_setting", "mix_branches",
    "setting_branches",
]

#: Lamb-Dicke parameter of the experiment (only ``eta * Omega0`` enters the engine).
ETA = 0.026
#: Neglected thermal tail weight.
THERMAL_TAIL = 1e-10
#: Ideal target of the symmetric real Cardioid(1,2) gate in this module's convention.
BELL_TARGET = np.array([1.0, 0.0, 0.0, 1.0j]) / np.sqrt(2.0)

_RULE_TOL = 1e-14        # displaced thermal population allowed on levels >= n_fock - 1
_MONITOR_TOL = 1e-12     # top-level population allowed along the integration


# --------------------------------------------------------------------------- inputs


def field_amplitudes(blue, red):
    """Engine amplitudes ``(b, c)`` from envelope Fourier coefficients.

    Parameters
    ----------
    blue, red : array_like of complex
        Fourier coefficients of the complex optical envelope at
        ``+(nu + n xi0)`` and ``-(nu + n xi0)`` in the convention
        ``y(t) = sum y_k exp(+i 2 pi f_k t)`` (as returned by
        :func:`dpdfit.models.spectrum.field_tone_powers`), normalised field units.

    Returns
    -------
    b, c : ndarray of complex
        ``conj(blue)``, ``conj(red)``: the amplitudes ``E_k`` of the
        positive-frequency field ``sum E_k exp(-i(omega_L + 2 pi f_k) t)``
        (module docstring).
    """
    return np.conj(np.asarray(blue, dtype=complex)), np.conj(np.asarray(red, dtype=complex))


def _tones(b, c, n):
    b = np.atleast_1d(np.asarray(b, dtype=complex))
    c = np.atleast_1d(np.asarray(c, dtype=complex))
    n_arr = np.atleast_1d(np.asarray(n))
    if not (b.ndim == c.ndim == n_arr.ndim == 1 and b.shape == c.shape == n_arr.shape):
        raise InputError("b, c and n must be 1-D arrays of equal length")
    if b.size == 0:
        raise InputError("need at least one tone")
    if not np.all(np.isfinite(n_arr)) or not np.all(n_arr == np.round(n_arr)):
        raise InputError(f"harmonic indices n must be integers, got {n_arr}")
    n_arr = n_arr.astype(int)
    if len(set(n_arr.tolist())) != n_arr.size:
        raise InputError(f"harmonic indices must be distinct, got {tuple(n_arr)}")
    if not (np.all(np.isfinite(b)) and np.all(np.isfinite(c))):
        raise InputError("tone amplitudes must be finite")
    return b, c, n_arr


def _positive(name, value, allow_zero=False, allow_inf=False):
    v = float(value)
    ok = (v >= 0 if allow_zero else v > 0) and (allow_inf or np.isfinite(v)) and not np.isnan(v)
    if not ok:
        raise InputError(f"{name} must be {'>= 0' if allow_zero else '> 0'}"
                         f"{'' if allow_inf else ' and finite'}, got {value}")
    return v


def _probability(name, value):
    v = float(value)
    if not 0.0 <= v <= 1.0:
        raise InputError(f"{name} must lie in [0, 1], got {value}")
    return v


def thermal_weights(nbar, tail=THERMAL_TAIL):
    """Thermal Fock weights ``p_m``, ``m = 0..m_max`` (tail < ``tail``), renormalised.

    Parameters
    ----------
    nbar : float
        Mean phonon number (>= 0).
    tail : float
        Largest neglected weight ``(nbar/(1+nbar))^(m_max+1)``.
    """
    nbar = _positive("nbar", nbar, allow_zero=True)
    if nbar == 0:
        return np.array([1.0])
    q = nbar / (1.0 + nbar)
    m_max = max(0, int(math.ceil(math.log(tail) / math.log(q))) - 1)
    while q ** (m_max + 1) >= tail:
        m_max += 1
    while m_max > 0 and q ** m_max < tail:
        m_max -= 1
    p = (1.0 - q) * q ** np.arange(m_max + 1)
    return p / p.sum()


def displacement_bound(b, c, n, eta_Omega0, xi0, t_max=None, n_ions=2):
    """Triangle-inequality bound on the spin-dependent displacement up to ``t_max``.

    ``B = n_ions (eta Omega0/2) max(sum |b_n| w_n, sum |c_n| w_n)``,
    ``w_n = min(2/|delta_n|, t_max)`` (``t_max`` for ``n = 0``); dimensionless
    (units of the zero-point amplitude).  ``t_max`` defaults to ``1/xi0``.
    """
    b, c, n = _tones(b, c, n)
    t_max = 1.0 / xi0 if t_max is None else float(t_max)
    delta = np.abs(2 * np.pi * n * xi0)
    w = np.where(n == 0, t_max, np.minimum(2.0 / np.where(n == 0, 1.0, delta), t_max))
    return n_ions * 0.5 * eta_Omega0 * max(float(np.sum(np.abs(b) * w)),
                                           float(np.sum(np.abs(c) * w)))


@functools.lru_cache(maxsize=256)
def _cutoff_cached(B_key: int, nbar_key: float, tol: float) -> int:
    B = B_key / 1000.0
    p = thermal_weights(nbar_key)
    m_max = p.size - 1
    big = int(math.ceil((math.sqrt(m_max) + B) ** 2 + 20 * B + 80))
    if big > 800:          # huge displacement: conservative closed-form rule instead
        x = math.sqrt(m_max) + B
        return int(math.ceil(x * x + 12.0 * B + 20.0))
    k = np.arange(1, big)
    gen = np.diag(B * np.sqrt(k), -1) - np.diag(B * np.sqrt(k), 1)   # B (a^dag - a)
    D = expm(gen)[:, :m_max + 1]
    pop = np.abs(D) ** 2 @ p                       # displaced thermal populations
    tail = np.cumsum(pop[::-1])[::-1]              # tail[k] = population on levels >= k
    ok = np.nonzero(tail < tol)[0]
    # levels >= n_fock - 1 carry < tol; keep >= 4 levels above the thermal m_max
    n_fock = int(ok[0]) + 1 if ok.size else big
    return max(n_fock, m_max + 5, 6)


def fock_cutoff(nbar, B, tol=_RULE_TOL):
    """Fock dimension for a thermal state displaced by up to ``B`` (module docstring)."""
    return _cutoff_cached(int(math.ceil(max(B, 0.0) * 1000)), float(nbar), float(tol))


def calibrate_xi0(b, c, n, eta_Omega0, gate=(1, 2)):
    """Gate detuning ``xi0`` [Hz] that makes the ideal geometric phase pi/2.

    Same calibration as :func:`dpdfit.models.fidelity.calibrate_g`,
    ``g = eta Omega/(2 pi xi0) = (1/2) (sum_gate r_n^2/n)^(-1/2)``, with the
    absolute gate-tone amplitudes averaged over the two sidebands in dB
    (``r_n^2 = |b_n| |c_n|``, the geometric mean of the red and blue
    amplitudes, as the ``mean`` row of ``dpdfit sweep`` averages dB), i.e. ::

        xi0 = (eta Omega0 / pi) sqrt(sum_{n in gate} |b_n| |c_n| / n).

    Why the geometric mean: a red/blue pair of amplitudes ``b, c`` drives a
    ``sigma_phi`` force ``~ (b + c)/2`` and an orthogonal ``sigma_phi+pi/2``
    force ``~ (b - c)/2`` whose entangling phases have opposite signs, so the
    net phase is ``~ [(b + c)^2 - (b - c)^2]/4 = b c``.  Checked against the
    exact dynamics: for ``b = (1+e) r``, ``c = (1-e) r`` (``e = 0.1``) the
    infidelity at this ``xi0`` is 1.5e-4 (optimum over ``xi0``: 1.2e-4), with
    the arithmetic mean 3.0e-4, with the power mean 5.6e-4.  For realistic
    asymmetries (0.2 dB, ``e ~ 0.012``) the three differ by < 1e-7 in
    fidelity.

    Parameters
    ----------
    b, c : array_like of complex
        Blue and red tone amplitudes (normalised field units).
    n : array_like of int
        Harmonic indices.
    eta_Omega0 : float
        ``eta * Omega0`` [rad/s] (Rabi frequency per unit field amplitude).
    gate : tuple of int
        Gate harmonics (positive).

    Returns
    -------
    float
        ``xi0`` [Hz].  The gate time is ``1/xi0``.
    """
    b, c, n = _tones(b, c, n)
    eta_Omega0 = _positive("eta_Omega0", eta_Omega0)
    mask = np.isin(n, np.asarray(gate))
    if not mask.any():
        raise InputError(f"none of the gate harmonics {tuple(gate)} is among the tones {tuple(n)}")
    if np.any(n[mask] <= 0):
        raise InputError("gate harmonics must be positive integers")
    s = float(np.sum(np.abs(b[mask]) * np.abs(c[mask]) / n[mask]))
    if s <= 0:
        raise InputError("gate tones have zero amplitude")
    return eta_Omega0 / np.pi * np.sqrt(s)


# --------------------------------------------------------------------------- dynamics


class _Drive:
    """K(tau)/xi0 for one or two ions, in dimensionless time."""

    def __init__(self, b, c, n, eta_Omega0, xi0, n_ions):
        scale = 0.5 * eta_Omega0 / xi0
        self.b = scale * b
        self.cc = scale * np.conj(c)
        self.w = -2j * np.pi * n
        self.n_ions = n_ions
        self.dim = 2 ** n_ions

    def K(self, tau):
        e = np.exp(self.w * tau)
        beta = self.b @ e
        gam = self.cc @ e
        k1 = np.array([[0.0, -1j * gam], [1j * beta, 0.0]])  # i(beta sigma+ - gamma sigma-)
        if self.n_ions == 1:
            return k1
        K = np.zeros((4, 4), dtype=complex)
        # K1 (x) 1 + 1 (x) K1, basis |00>,|01>,|10>,|11>
        K[2:, :2] += k1[1, 0] * np.eye(2)
        K[:2, 2:] += k1[0, 1] * np.eye(2)
        K[1, 0] += k1[1, 0]
        K[3, 2] += k1[1, 0]
        K[0, 1] += k1[0, 1]
        K[2, 3] += k1[0, 1]
        return K


def _step_loop(fun, y0, tau_out, rtol, atol, reduce, top_of):
    """Integrate with DOP853 and return ``[reduce(y(tau)) for tau in tau_out]``.

    ``top_of(y)`` is evaluated after every step; its maximum is returned too.
    """
    tau_out = np.asarray(tau_out, dtype=float)
    order = np.argsort(tau_out, kind="stable")
    ts = tau_out[order]
    out = [None] * ts.size
    i = 0
    top = top_of(y0)
    nfev = 0
    while i < ts.size and ts[i] <= 0.0:
        out[order[i]] = reduce(y0)
        i += 1
    if i < ts.size:
        solver = DOP853(fun, 0.0, y0, float(ts[-1]), rtol=rtol, atol=atol)
        while i < ts.size:
            msg = solver.step()
            if solver.status == "failed":
                raise RuntimeError(f"DOP853 failed: {msg}")
            j = i
            while j < ts.size and ts[j] <= solver.t:
                j += 1
            if j > i:
                if ts[j - 1] == solver.t and j - i == 1:
                    ys = solver.y[:, None]
                else:
                    ys = solver.dense_output()(ts[i:j])
                    if ys.ndim == 1:
                        ys = ys[:, None]
                for kk in range(j - i):
                    out[order[i + kk]] = reduce(ys[:, kk])
                i = j
            top = max(top, top_of(solver.y))
            if solver.status == "finished" and i < ts.size:
                raise RuntimeError("integration ended before the last requested time")
        nfev = solver.nfev
    return out, top, nfev


def _check_times(times):
    t = np.asarray(times, dtype=float)
    if not np.all(np.isfinite(t)) or np.any(t < 0):
        raise InputError("times must be finite and >= 0 (s)")
    return t


def _schrodinger(drive, n_fock, p, tau_out, rtol, atol, init=0):
    d = drive.dim
    M = p.size
    sq = np.sqrt(np.arange(1, n_fock))[None, :, None]
    shape = (d, n_fock, M)

    def rhs(tau, y):
        psi = y.reshape(shape)
        K = drive.K(tau)
        up = sq * psi[:, :-1]                    # a^dag psi, levels 1..N-1
        dn = sq * psi[:, 1:]                     # a psi,     levels 0..N-2
        out = np.zeros(shape, dtype=complex)
        out[:, 1:] = (K @ up.reshape(d, -1)).reshape(d, n_fock - 1, M)
        out[:, :-1] += (K.conj().T @ dn.reshape(d, -1)).reshape(d, n_fock - 1, M)
        return (-1j * out).ravel()

    psi0 = np.zeros(shape, dtype=complex)
    psi0[init, np.arange(M), np.arange(M)] = 1.0     # |spin init> (x) |m>
    sp = np.sqrt(p)

    def reduce(y):
        psi = y.reshape(shape) * sp
        return np.einsum("ikm,jkm->ij", psi, psi.conj())

    def top_of(y):
        psi = y.reshape(shape)
        return float(np.sum(p * np.sum(np.abs(psi[:, -1, :]) ** 2, axis=0)))

    return _step_loop(rhs, psi0.ravel(), tau_out, rtol, atol, reduce, top_of)


def _lindblad(drive, n_fock, p, tau_out, gamma, heat, rtol, atol, init=0, gamma_c=0.0):
    """Master equation; ``gamma = 1/(T2 xi0)``, ``heat = ndot/xi0``, ``gamma_c = 1/(T2c xi0)``
    (correlated dephasing) per unit tau."""
    d = drive.dim
    N = n_fock
    DN = d * N
    sq = np.sqrt(np.arange(1, N))
    sq_r = sq[None, :, None]
    # Hamming distance between spin labels: (gamma/2) sum_j (z_j z_j' - 1) = -gamma * dist
    lab = np.arange(d)
    dist = np.zeros((d, d))
    zsum = np.zeros(d)
    for j in range(drive.n_ions):
        bit = (lab >> j) & 1
        dist += bit[:, None] != bit[None, :]
        zsum += 1 - 2 * bit
    # correlated dephasing L = sqrt(gamma_c/2) sum_j Z_j: -(gamma_c/4) (S_i - S_j)^2 on rho_ij
    corr = 0.25 * (zsum[:, None] - zsum[None, :]) ** 2
    k = np.arange(N, dtype=float)
    v = k + np.where(k < N - 1, k + 1, 0.0)          # diag(a^dag a + a a^dag), truncated
    # diagonal part of the dissipator (dephasing + heating anticommutator), real,
    # applied to the float view of rho (re/im interleaved on the last axis)
    diag = ((-gamma * dist - gamma_c * corr)[:, None, :, None]
            - 0.5 * heat * (v[:, None] + v[None, :])[None, :, None, :])
    diag2 = np.repeat(np.broadcast_to(diag, (d, N, d, N)), 2, axis=-1)
    sqsq2 = np.repeat(heat * np.outer(sq, sq)[None, :, None, :], 2, axis=-1)
    sq_c = sq_r.astype(complex)
    tmp = np.empty((d, N - 1, DN), dtype=complex)
    up = np.empty((d, N - 1, DN), dtype=complex)
    dn = np.empty((d, N - 1, DN), dtype=complex)
    dissipative = bool(gamma or heat or gamma_c)

    def rhs(tau, y):
        R = y.reshape(d, N, DN)
        mK = -1j * drive.K(tau)
        # A = -i H rho, H = K a^dag + K^dag a
        np.multiply(sq_c, R[:, :-1], out=tmp)
        np.matmul(mK, tmp.reshape(d, -1), out=up.reshape(d, -1))
        np.multiply(sq_c, R[:, 1:], out=tmp)
        np.matmul(-mK.conj().T, tmp.reshape(d, -1), out=dn.reshape(d, -1))
        A = np.empty((d, N, DN), dtype=complex)
        A[:, 0] = dn[:, 0]
        np.add(up[:, :-1], dn[:, 1:], out=A[:, 1:-1])
        A[:, -1] = up[:, -1]
        A = A.reshape(DN, DN)
        out = np.empty((DN, DN), dtype=complex)
        np.conjugate(A.T, out=out)
        out += A                                         # -i [H, rho] = A + A^dag
        if dissipative:
            rf = y.view(np.float64).reshape(d, N, d, 2 * N)
            of = out.view(np.float64).reshape(d, N, d, 2 * N)
            of += diag2 * rf
            if heat:
                of[:, :-1, :, :-2] += sqsq2 * rf[:, 1:, :, 2:]      # a rho a^dag
                of[:, 1:, :, 2:] += sqsq2 * rf[:, :-1, :, :-2]      # a^dag rho a
        return out.ravel()

    rho0 = np.zeros((d, N, d, N), dtype=complex)
    m = np.arange(p.size)
    rho0[init, m, init, m] = p
    sidx = np.arange(d)

    def reduce(y):
        return np.einsum("ikjk->ij", y.reshape(d, N, d, N))

    def top_of(y):
        r4 = y.reshape(d, N, d, N)
        return float(np.real(np.sum(r4[sidx, N - 1, sidx, N - 1])))

    return _step_loop(rhs, rho0.ravel(), tau_out, rtol, atol, reduce, top_of)


def _run(kind, b, c, n, eta_Omega0, xi0, times, nbar, n_fock, rtol, atol, n_ions,
         gamma=0.0, heat=0.0, initial=0, gamma_c=0.0):
    b, c, n = _tones(b, c, n)
    eta_Omega0 = _positive("eta_Omega0", eta_Omega0, allow_zero=True)
    xi0 = _positive("xi0", xi0)
    if n_ions not in (1, 2):
        raise InputError(f"n_ions must be 1 or 2, got {n_ions}")
    if int(initial) != initial or not 0 <= initial < 2 ** n_ions:
        raise InputError(f"initial spin state must be 0..{2 ** n_ions - 1}, got {initial}")
    t = _check_times(times)
    scalar = t.ndim == 0
    t1 = np.atleast_1d(t)
    p = thermal_weights(nbar)
    t_max = float(t1.max()) if t1.size else 0.0
    B = displacement_bound(b, c, n, eta_Omega0, xi0, max(t_max, 1e-300), n_ions)
    auto = n_fock is None
    N = fock_cutoff(nbar, B) if auto else int(n_fock)
    if N < p.size + 1:
        raise InputError(f"n_fock={N} too small for the thermal sum (m_max={p.size - 1})")
    drive = _Drive(b, c, n, eta_Omega0, xi0, n_ions)
    tau = t1 * xi0
    for _ in range(6):
        if kind == "pure":
            out, top, nfev = _schrodinger(drive, N, p, tau, rtol, atol, int(initial))
        else:
            out, top, nfev = _lindblad(drive, N, p, tau, gamma, heat, rtol, atol, int(initial),
                                       gamma_c)
        if not auto or top < _MONITOR_TOL:
            break
        N = int(math.ceil(1.3 * N)) + 4
    else:
        raise RuntimeError(f"Fock cutoff did not converge (top-level population {top:g} "
                           f"at n_fock={N})")
    rho = np.array(out).reshape((t1.size, drive.dim, drive.dim)) if out else \
        np.zeros((0, drive.dim, drive.dim), dtype=complex)
    rho = 0.5 * (rho + np.conj(np.swapaxes(rho, -1, -2)))
    info = {"n_fock": N, "m_max": p.size - 1, "B": B, "top_population": top, "nfev": nfev}
    return (rho[0] if scalar else rho), info


def propagate(b, c, n, eta_Omega0, xi0, times, nbar, n_fock=None, rtol=1e-9, atol=1e-11,
              *, n_ions=2, initial=0, return_info=False):
    """Reduced spin density matrices by brute-force Schrodinger integration.

    Starts from ``|0...0> (x) rho_thermal(nbar)``; every thermal Fock state is
    a column of one matrix ODE in spin (x) truncated Fock space, integrated in
    ``tau = t xi0`` with DOP853.  No decoherence (see :func:`propagate_lindblad`).

    Parameters
    ----------
    b, c : array_like of complex, shape (T,)
        Blue / red tone amplitudes ``E_k`` (module docstring; normalised field
        units).
    n : array_like of int, shape (T,)
        Harmonic indices (any integers, distinct).
    eta_Omega0 : float
        ``eta * Omega0`` [rad/s].
    xi0 : float
        Tone spacing [Hz]: tone ``n`` is detuned by ``n xi0`` from the sideband.
    times : float or array_like
        Times [s] (any order; 0 allowed).
    nbar : float
        Initial mean phonon number of the thermal mode.
    n_fock : int, optional
        Fock dimension; automatic by default (module docstring).
    rtol, atol : float
        DOP853 tolerances (amplitudes are O(1)).
    n_ions : {2, 1}
        Two ions (4x4 result) or one ion alone (2x2; the prep-error branch).
    initial : int
        Initial spin basis state (index into ``|00>, |01>, |10>, |11>``, or
        ``|0>, |1>`` for one ion); default ``|0...0>``.
    return_info : bool
        Also return ``{"n_fock", "m_max", "B", "top_population", "nfev"}``.

    Returns
    -------
    rho : ndarray of complex, shape (..., 4, 4)
        Basis ``|00>, |01>, |10>, |11>`` (``(..., 2, 2)`` for one ion), one per time.
    """
    rho, info = _run("pure", b, c, n, eta_Omega0, xi0, times, nbar, n_fock, rtol, atol, n_ions,
                     initial=initial)
    return (rho, info) if return_info else rho


def propagate_lindblad(b, c, n, eta_Omega0, xi0, times, nbar, *, T2=np.inf, ndot=0.0,
                       n_fock=None, rtol=1e-9, atol=1e-11, n_ions=2, initial=0,
                       T2_corr=np.inf, return_info=False):
    """Reduced spin density matrices from the Lindblad master equation.

    Same model and arguments as :func:`propagate`, plus ::

        d rho/dt = -i [H, rho] + (1/(2 T2)) sum_j (Z_j rho Z_j - rho)
                   + ndot (a rho a^dag + a^dag rho a - {a^dag a + a a^dag, rho}/2).

    Parameters
    ----------
    T2 : float
        Qubit coherence time [s] (``inf``: no dephasing).
    ndot : float
        Heating rate [quanta/s].
    T2_corr : float
        Coherence time [s] of *correlated* (common-mode) dephasing, Lindblad
        operator ``sqrt(1/(2 T2_corr)) (Z_1 + Z_2)``: each single-ion coherence
        decays as ``exp(-t/T2_corr)`` as for ``T2``, but ``|00><11|`` four times as
        fast (twice as fast as with independent noise), ``|01><10|`` not at all.
    """
    T2 = _positive("T2", T2, allow_inf=True)
    T2_corr = _positive("T2_corr", T2_corr, allow_inf=True)
    ndot = _positive("ndot", ndot, allow_zero=True)
    xi0f = _positive("xi0", xi0)
    gamma = 0.0 if np.isinf(T2) else 1.0 / (T2 * xi0f)
    gamma_c = 0.0 if np.isinf(T2_corr) else 1.0 / (T2_corr * xi0f)
    rho, info = _run("lindblad", b, c, n, eta_Omega0, xi0, times, nbar, n_fock, rtol, atol,
                     n_ions, gamma=gamma, heat=ndot / xi0f, initial=initial, gamma_c=gamma_c)
    return (rho, info) if return_info else rho


# --------------------------------------------------------------------------- measurement


def analysis_rotation(phi):
    """``R(phi) = exp(-i pi/4 (cos phi X + sin phi Y))``, shape ``phi.shape + (2, 2)``."""
    phi = np.asarray(phi, dtype=float)
    s = 1 / np.sqrt(2)
    R = np.empty(phi.shape + (2, 2), dtype=complex)
    R[..., 0, 0] = s
    R[..., 1, 1] = s
    R[..., 0, 1] = -1j * s * np.exp(-1j * phi)
    R[..., 1, 0] = -1j * s * np.exp(1j * phi)
    return R


def outcome_probabilities(rho):
    """Diagonal of ``rho`` (real, clipped at 0): probabilities of ``00, 01, 10, 11`` or ``0, 1``."""
    rho = np.asarray(rho)
    return np.clip(np.real(np.diagonal(rho, axis1=-2, axis2=-1)), 0.0, None)


def parity_outcomes(rho, phases):
    """Outcome probabilities after the analysis pulse ``R(phi)`` on every ion.

    ``rho`` (4, 4) or (2, 2); returns shape ``(len(phases), 4)`` or ``(len(phases), 2)``.
    """
    rho = np.asarray(rho)
    R = analysis_rotation(np.atleast_1d(phases))
    if rho.shape[-1] == 4:
        R = np.einsum("kab,kcd->kacbd", R, R).reshape(-1, 4, 4)
    out = R @ rho @ np.conj(np.swapaxes(R, -1, -2))
    return outcome_probabilities(out)


def confusion(p4, p_det):
    """Apply independent per-ion readout errors to 4-outcome (or 2-outcome) probabilities.

    ``p_det`` is one probability (symmetric) or a pair ``(e01, e10)``: ``e01``
    the probability that a bright ``|0>`` ion reads dark (1), ``e10`` that a
    dark ``|1>`` ion reads bright (0).
    """
    p4 = np.asarray(p4, dtype=float)
    e01, e10 = (p_det, p_det) if np.ndim(p_det) == 0 else (float(p_det[0]), float(p_det[1]))
    C = np.array([[1 - e01, e10], [e01, 1 - e10]])           # C[read, true]
    return p4 @ (np.kron(C, C).T if p4.shape[-1] == 4 else C.T)


def _collapse(p4):
    """(P00, P01+P10, P11) from four outcome probabilities."""
    p4 = np.asarray(p4)
    return np.stack([p4[..., 0], p4[..., 1] + p4[..., 2], p4[..., 3]], axis=-1)


def bell_fidelity(rho, target=None):
    """``<target|rho|target>``; default target :data:`BELL_TARGET` ``(|00> + i|11>)/sqrt2``."""
    t = BELL_TARGET if target is None else np.asarray(target, dtype=complex)
    t = t / np.linalg.norm(t)
    return float(np.real(np.conj(t) @ np.asarray(rho) @ t))


def bell_fidelity_max(rho):
    """Fidelity with the best ``(|00> + e^{i chi}|11>)/sqrt2``: ``(P00 + P11)/2 + |rho_{00,11}|``.

    This is what populations plus a parity fringe of free phase measure.
    """
    rho = np.asarray(rho)
    return float(0.5 * np.real(rho[0, 0] + rho[3, 3]) + abs(rho[0, 3]))


def gate_target(b, c, n, xi0, gate=(1, 2), n_fock=None, rtol=1e-10, atol=1e-12):
    """Target state of the setting's own gate tones (IM-free, perfectly calibrated).

    The spin state produced at ``T = 1/xi0`` from ``|00>`` at ``nbar = 0``,
    without decoherence, by the tones ``n in gate`` alone (with their actual
    complex red/blue amplitudes) at the ``eta Omega0`` that calibrates them to
    the given ``xi0`` (:func:`calibrate_xi0`).  Returned as the principal
    eigenvector of that (nearly pure) state, global phase fixed so that the
    ``|00>`` component is real positive.  The fidelity with it measures what
    the intermodulation tones, the power and rate errors and the decoherence
    do, not the frame (Bell phase) set by the common phase and red/blue
    imbalance of the gate tones; it is the analogue of the target used to
    validate :mod:`dpdfit.models.fidelity` against ``tests/exact_ms.py``.
    """
    b, c, n = _tones(b, c, n)
    mask = np.isin(n, np.asarray(gate))
    eO = _positive("xi0", xi0) / calibrate_xi0(b[mask], c[mask], n[mask], 1.0, gate)
    rho = propagate(b[mask], c[mask], n[mask], eO, xi0, 1.0 / xi0, 0.0, n_fock=n_fock,
                    rtol=rtol, atol=atol)
    w, v = np.linalg.eigh(rho)
    psi = v[:, -1]
    return psi * np.exp(-1j * np.angle(psi[0])) if abs(psi[0]) > 0 else psi


# --------------------------------------------------------------------------- experiment


def _branches(b, c, n, eta_Omega0, xi0, times, nbar, T2, ndot, p_prep, n_fock, rtol, atol,
              p_flip=0.0):
    """Spin states of the preparation branches at ``times``.

    Returns ``(rho2, rho1, info, flips)``: the two-ion branch from ``|00>``,
    the single driven ion from ``|0>`` (if ``p_prep > 0``: the other ion is a
    spectator) and, if ``p_flip > 0``, ``flips = (rho2 from |01>, rho2 from |11>,
    rho1 from |1>)`` (ions prepared in the wrong qubit state; the last only if
    ``p_prep > 0`` too), else None.
    """
    lind = not (np.isinf(T2) and ndot == 0)
    kw = dict(n_fock=n_fock, rtol=rtol, atol=atol, return_info=True)
    if lind:
        f = functools.partial(propagate_lindblad, T2=T2, ndot=ndot)
    else:
        f = propagate
    rho2, info2 = f(b, c, n, eta_Omega0, xi0, times, nbar, n_ions=2, **kw)
    rho1 = info1 = None
    if p_prep > 0:
        rho1, info1 = f(b, c, n, eta_Omega0, xi0, times, nbar, n_ions=1, **kw)
    flips = None
    if p_flip > 0:
        r01, _ = f(b, c, n, eta_Omega0, xi0, times, nbar, n_ions=2, initial=1, **kw)
        r11, _ = f(b, c, n, eta_Omega0, xi0, times, nbar, n_ions=2, initial=3, **kw)
        r1f = None
        if p_prep > 0:
            r1f, _ = f(b, c, n, eta_Omega0, xi0, times, nbar, n_ions=1, initial=1, **kw)
        flips = (r01, r11, r1f)
    return rho2, rho1, {"two_ion": info2, "one_ion": info1, "master_equation": lind}, flips


def _spectator(p1):
    """Four outcomes of 'one ion a spectator (reads 0), the other driven' summed over
    which ion is out: ``p1`` (..., 2) are the driven ion's outcomes."""
    p1 = np.asarray(p1, dtype=float)
    one = np.zeros(p1.shape[:-1] + (4,))
    # ion 1 out (reads 0), ion 2 driven: outcomes 00, 01
    one[..., 0] += p1[..., 0]
    one[..., 1] += p1[..., 1]
    # ion 2 out, ion 1 driven: outcomes 00, 10
    one[..., 0] += p1[..., 0]
    one[..., 2] += p1[..., 1]
    return one


def mix_branches(p2, p1, p_prep, p_flip=0.0, p2_01=None, p2_11=None, p1_1=None):
    """Four-outcome probabilities from the preparation branches.

    Each ion is independently a *spectator* with probability ``p_prep`` (pumped
    into a level that takes no part in the gate; reads bright, 0), prepared in
    the wrong qubit state ``|1>`` with probability ``p_flip`` (driven by the
    gate), and right otherwise.  ``p2``: (..., 4) outcomes of the two-ion
    branch from ``|00>``; ``p1``: (..., 2) of one driven ion from ``|0>``;
    ``p2_01``: two ions from ``|01>`` (``|10>`` is its mirror: the ions are
    driven alike); ``p2_11``: from ``|11>`` (None: ``p2`` with both bits flipped,
    exact for the ideal interaction, which anticommutes with ``X X``, and of
    weight ``p_flip^2`` anyway); ``p1_1``: one driven ion from ``|1>``.
    """
    q, f = p_prep, p_flip
    g = 1.0 - q - f
    out = g ** 2 * np.asarray(p2, dtype=float)
    if q > 0:
        out = out + q * g * _spectator(p1)
        out[..., 0] += q ** 2
    if f > 0:
        p01 = np.asarray(p2_01, dtype=float)
        out = out + f * g * (p01 + p01[..., [0, 2, 1, 3]])
        p11 = (np.asarray(p2, dtype=float)[..., ::-1] if p2_11 is None
               else np.asarray(p2_11, dtype=float))
        out = out + f * f * p11
        if q > 0:
            out = out + q * f * _spectator(p1_1)
    return out


def _outcomes(rho2, rho1, flips, p_prep, p_flip, reduce):
    """Mixed four-outcome probabilities of the branches, ``reduce`` = outcome map of a state."""
    o1 = None if rho1 is None else reduce(rho1)
    if flips is None:
        return mix_branches(reduce(rho2), o1, p_prep)
    r01, r11, r1f = flips
    return mix_branches(reduce(rho2), o1, p_prep, p_flip, reduce(r01), reduce(r11),
                        None if r1f is None else reduce(r1f))


def _prep_probabilities(p_prep, p_flip):
    p_prep = _probability("p_prep", p_prep)
    p_flip = _probability("p_flip", p_flip)
    if p_prep + p_flip > 1:
        raise InputError(f"p_prep + p_flip must not exceed 1, got {p_prep + p_flip}")
    return p_prep, p_flip


def _detection(p_det):
    if np.ndim(p_det) == 0:
        return _probability("p_det", p_det)
    if np.shape(p_det) != (2,):
        raise InputError(f"p_det must be a probability or a pair (e01, e10), got {p_det!r}")
    return (_probability("e01", p_det[0]), _probability("e10", p_det[1]))


def populations(b, c, n, eta_Omega0, xi0, times=None, *, nbar=0.1, T2=50e-3, ndot=5.0,
                p_prep=0.003, p_det=5e-5, p_flip=0.0, n_fock=None, rtol=1e-9, atol=1e-11):
    """Measured populations ``(P00, P01+P10, P11)`` with all imperfections.

    ``times`` [s] defaults to the gate time ``1/xi0``; returns shape
    ``times.shape + (3,)``.  Other arguments as in :func:`simulate_setting`.
    """
    p_prep, p_flip = _prep_probabilities(p_prep, p_flip)
    p_det = _detection(p_det)
    times = 1.0 / xi0 if times is None else times
    t = np.asarray(times, dtype=float)
    rho2, rho1, _, flips = _branches(b, c, n, eta_Omega0, xi0, t, nbar, T2, ndot, p_prep,
                                     n_fock, rtol, atol, p_flip)
    p4 = _outcomes(rho2, rho1, flips, p_prep, p_flip, outcome_probabilities)
    return _collapse(confusion(p4, p_det))


def parity_even(b, c, n, eta_Omega0, xi0, phases=None, *, nbar=0.1, T2=50e-3, ndot=5.0,
                p_prep=0.003, p_det=5e-5, p_flip=0.0, n_fock=None, rtol=1e-9, atol=1e-11):
    """``P_even(phi)`` after gate (``T = 1/xi0``) + analysis pulse, all imperfections."""
    p_prep, p_flip = _prep_probabilities(p_prep, p_flip)
    p_det = _detection(p_det)
    phases = np.arange(16) * 2 * np.pi / 16 if phases is None else np.asarray(phases, float)
    rho2, rho1, _, flips = _branches(b, c, n, eta_Omega0, xi0, 1.0 / xi0, nbar, T2, ndot,
                                     p_prep, n_fock, rtol, atol, p_flip)
    p4 = _outcomes(rho2, rho1, flips, p_prep, p_flip,
                   functools.partial(_parity_of, phases=phases))
    p4 = confusion(p4, p_det)
    return p4[..., 0] + p4[..., 3]


def _parity_of(rho, phases):
    return parity_outcomes(rho, phases)


def setting_branches(b, c, n, eta_Omega0, xi0, *, nbar=0.1, T2=50e-3, ndot=5.0,
                     phases=None, scan_times=None, power_error_db=0.0, spectator=True,
                     flip=True, n_fock=None, rtol=1e-9, atol=1e-11, T2_corr=np.inf) -> dict:
    """Raw outcome probabilities of the preparation branches of one setting.

    No preparation mixing and no detection error: what :func:`mix_branches`
    and :func:`confusion` turn into measured probabilities for *any*
    ``p_prep``, ``p_flip`` and detection errors, exactly and without another
    integration (the diagnosis fits those as nuisances).

    Returns
    -------
    dict
        ``p2`` (1 + S, 4): two ions from ``|00>`` at the gate time then the scan
        times; ``par2`` (K, 4): after the analysis pulse at ``phases``;
        with ``spectator``: ``p1``, ``par1`` (one driven ion from ``|0>``);
        with ``flip``: ``p2_01``, ``par2_01`` (two ions from ``|01>``); with
        both: ``p1_1``, ``par1_1`` (one driven ion from ``|1>``); and
        ``phases``, ``times``.
    """
    T2 = _positive("T2", T2, allow_inf=True)
    ndot = _positive("ndot", ndot, allow_zero=True)
    eO = _positive("eta_Omega0", eta_Omega0) * 10 ** (float(power_error_db) / 20)
    phases = (np.arange(16) * 2 * np.pi / 16 if phases is None
              else np.atleast_1d(np.asarray(phases, dtype=float)))
    T = 1.0 / _positive("xi0", xi0)
    scan = np.zeros(0) if scan_times is None else np.atleast_1d(_check_times(scan_times))
    times = np.concatenate([[T], scan])
    lind = not (np.isinf(T2) and ndot == 0 and np.isinf(T2_corr))
    f = (functools.partial(propagate_lindblad, T2=T2, ndot=ndot, T2_corr=T2_corr) if lind
         else propagate)
    kw = dict(n_fock=n_fock, rtol=rtol, atol=atol)
    out = {"phases": phases, "times": times}
    runs = [("2", 2, 0)] + ([("1", 1, 0)] if spectator else []) + (
        [("2_01", 2, 1)] if flip else []) + ([("1_1", 1, 1)] if spectator and flip else [])
    for name, ions, init in runs:
        rho = f(b, c, n, eO, xi0, times, nbar, n_ions=ions, initial=init, **kw)
        out["p" + name] = outcome_probabilities(rho)
        out["par" + name] = parity_outcomes(rho[0], phases)
    return out


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
    """Outcome probabilities of one experimental setting (see :func:`simulate_setting`).

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
        Fidelity with :func:`gate_target` of the setting's own gate tones
        (IM-free, calibrated, no decoherence): the loss caused by the
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


def simulate_setting(b, c, n, eta_Omega0, xi0, *, nbar=0.1, T2=50e-3, ndot=5.0,
                     p_prep=0.003, p_det=5e-5, parity_phases=None, scan_times=None,
                     power_error_db=0.0, n_fock=None, rtol=1e-9, atol=1e-11,
                     target=None, gate=(1, 2), p_flip=0.0) -> SettingProbabilities:
    """Outcome probabilities of one gate setting.

    The gate runs for ``T = 1/xi0`` with tones at ``n xi0`` from the sidebands;
    the dynamics use ``eta_Omega0 * 10**(power_error_db/20)`` (a laser-power
    error at gate time, with ``xi0`` kept as calibrated).  Dephasing and
    heating act during the gate (master equation); preparation and detection
    errors as described in the module docstring.

    Parameters
    ----------
    b, c, n : array_like
        Blue / red tone amplitudes (normalised field units, engine convention:
        see :func:`field_amplitudes`) and harmonic indices.
    eta_Omega0 : float
        ``eta * Omega0`` [rad/s].
    xi0 : float
        Tone spacing [Hz] (typically from :func:`calibrate_xi0`).
    nbar : float
        Mean thermal phonon number at the start of the gate.
    T2 : float
        Qubit coherence time [s] (``np.inf``: none).
    ndot : float
        Heating rate [quanta/s].
    p_prep : float
        Per-ion probability of a spectator (pumped out of the qubit; not driven,
        reads bright).
    p_det : float or (float, float)
        Per-ion detection error: one probability (symmetric) or ``(e01, e10)``
        (bright read dark, dark read bright).
    p_flip : float
        Per-ion probability of starting in the wrong qubit state ``|1>`` (driven).
    parity_phases : array_like, optional
        Analysis phases [rad]; default ``2 pi k/16``, ``k = 0..15``.
    scan_times : array_like, optional
        Gate durations [s] of a time scan (populations only).
    power_error_db : float
        Optical power error [dB] at gate time.
    target : array_like, optional
        Target state for ``fidelity`` (default :data:`BELL_TARGET`).
    gate : tuple of int
        Gate harmonics (for ``fidelity_gate``).

    Returns
    -------
    SettingProbabilities
    """
    t0 = time.perf_counter()
    xi0 = _positive("xi0", xi0)
    T2 = _positive("T2", T2, allow_inf=True)
    ndot = _positive("ndot", ndot, allow_zero=True)
    p_prep, p_flip = _prep_probabilities(p_prep, p_flip)
    p_det = _detection(p_det)
    if not np.isfinite(power_error_db):
        raise InputError(f"power_error_db must be finite, got {power_error_db}")
    eO = _positive("eta_Omega0", eta_Omega0) * 10 ** (float(power_error_db) / 20)
    phases = (np.arange(16) * 2 * np.pi / 16 if parity_phases is None
              else np.atleast_1d(np.asarray(parity_phases, dtype=float)))
    T = 1.0 / xi0
    scan = None if scan_times is None else np.atleast_1d(_check_times(scan_times))
    times = np.concatenate([[T], scan]) if scan is not None else np.array([T])
    rho2, rho1, info, flips = _branches(b, c, n, eO, xi0, times, nbar, T2, ndot, p_prep,
                                        n_fock, rtol, atol, p_flip)
    pops = _collapse(confusion(_outcomes(rho2, rho1, flips, p_prep, p_flip,
                                         outcome_probabilities), p_det))
    first = None if flips is None else tuple(None if r is None else r[0] for r in flips)
    par = _outcomes(rho2[0], None if rho1 is None else rho1[0], first, p_prep, p_flip,
                    functools.partial(parity_outcomes, phases=phases))
    par = _collapse(confusion(par, p_det))
    info["seconds"] = time.perf_counter() - t0
    return SettingProbabilities(
        xi0=xi0, T_gate=T, eta_Omega0=eO, pop=pops[0], parity_phases=phases,
        parity_probs=par, rho_gate=rho2[0], fidelity=bell_fidelity(rho2[0], target),
        fidelity_max=bell_fidelity_max(rho2[0]),
        fidelity_gate=bell_fidelity(rho2[0], gate_target(b, c, n, xi0, gate)),
        scan_times=scan, scan_pop=None if scan is None else pops[1:],
        params={"nbar": float(nbar), "T2": T2, "ndot": ndot, "p_prep": p_prep, "p_det": p_det,
                "p_flip": p_flip, "power_error_db": float(power_error_db),
                "eta_Omega0_calibrated": float(eta_Omega0)},
        info=info)
