"""The optical drive of the gate: tone amplitudes, the spin-motion coupling, the calibration.

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

``tests/helpers/exact_ms.py`` integrates ``S_x (f' a^dag + h.c.)`` with
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
``U = exp(-i (pi/8) S_y^2)``: ``|00> -> (|00> + i|11>)/sqrt(2)``
(:data:`dpdfit.models.gate_sim.states.BELL_TARGET`).
"""

from __future__ import annotations

import numpy as np

from dpdfit.core.defaults import ETA_LD
from dpdfit.errors import InputError

from .arguments import check_tones, positive

__all__ = ["ETA", "field_amplitudes", "calibrate_xi0", "Drive"]

#: Lamb-Dicke parameter of the experiment (only ``eta * Omega0`` enters the engine).
ETA = ETA_LD


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
    b, c, n = check_tones(b, c, n)
    eta_Omega0 = positive("eta_Omega0", eta_Omega0)
    mask = np.isin(n, np.asarray(gate))
    if not mask.any():
        raise InputError(f"none of the gate harmonics {tuple(gate)} is among the tones {tuple(n)}")
    if np.any(n[mask] <= 0):
        raise InputError("gate harmonics must be positive integers")
    s = float(np.sum(np.abs(b[mask]) * np.abs(c[mask]) / n[mask]))
    if s <= 0:
        raise InputError("gate tones have zero amplitude")
    return eta_Omega0 / np.pi * np.sqrt(s)


class Drive:
    """The coupling ``K(tau)/xi0`` of the Hamiltonian for one or two ions, in ``tau = t xi0``.

    ``H = sum_j [K_j a^dag + K_j^dag a]`` (module docstring); :meth:`K` returns
    the spin operator multiplying ``a^dag`` (``2 x 2`` or ``4 x 4``, basis
    ``|00>, |01>, |10>, |11>``).
    """

    def __init__(self, b, c, n, eta_Omega0, xi0, n_ions):
        scale = 0.5 * eta_Omega0 / xi0
        self.b = scale * b
        self.cc = scale * np.conj(c)
        self.w = -2j * np.pi * n
        self.n_ions = n_ions
        self.dim = 2 ** n_ions
        # where beta and gamma enter K (flat indices of the dim x dim matrix) and of its
        # adjoint: sigma+ of each ion (beta), sigma- (gamma)
        d = self.dim
        if n_ions == 1:
            rb, cb = np.array([1]), np.array([0])
        else:
            rb, cb = np.array([2, 3, 1, 3]), np.array([0, 1, 0, 2])
        self._beta_at, self._gam_at = rb * d + cb, cb * d + rb

    def coupling(self):
        """``(b, cc, w, beta_at, gam_at)``: what :meth:`minus_iK` is made of, as contiguous
        arrays for a compiled right-hand side (scaled blue amplitudes, conjugated scaled
        red ones, ``-2 pi i n``, and the flat indices where ``beta`` and ``gamma`` enter
        ``K``)."""
        return (np.ascontiguousarray(self.b, dtype=complex),
                np.ascontiguousarray(self.cc, dtype=complex),
                np.ascontiguousarray(self.w, dtype=complex),
                np.ascontiguousarray(self._beta_at, dtype=np.int64),
                np.ascontiguousarray(self._gam_at, dtype=np.int64))

    def minus_iK(self, tau):
        """``(-i K(tau)/xi0, -i K(tau)^dag/xi0)``: what the master equation applies on the
        left of ``a^dag rho`` and ``a rho`` (:meth:`K`'s entries placed directly: the same
        values as ``-1j * K`` and ``-(-1j * K).conj().T``, without the small matrix
        algebra)."""
        e = np.exp(self.w * tau)
        beta = self.b @ e
        gam = self.cc @ e
        d = self.dim
        mK = np.zeros(d * d, dtype=complex)
        mK[self._beta_at] = beta
        mK[self._gam_at] = -gam
        mKd = np.zeros(d * d, dtype=complex)
        mKd[self._gam_at] = -np.conj(beta)
        mKd[self._beta_at] = np.conj(gam)
        return mK.reshape(d, d), mKd.reshape(d, d)

    def K(self, tau):
        """``K(tau)/xi0 = (eta Omega0/2 xi0) i [beta sigma+ - gamma sigma-]``, summed over ions."""
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
