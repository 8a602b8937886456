"""A physical acousto-optic modulator, used as the *truth* behind synthetic recordings.

dpdfit fits polynomials to calibration data (paper, main-text Eq. 3 and
Supplement Eq. S1).  To test those fits honestly the synthetic data must come from
a model that is *not* a polynomial, so that the K=8 / K=5 fits carry their
real, small model error.  This module is that model:

1. **RF power amplifier** with soft (tanh) compression.  The acoustic wave
   amplitude, normalised to the Bragg pi/2 point, is

   .. math:: u(A) = \\tanh(g A) / \\tanh(g),

   so that ``u(1) = 1``: ``A = 1`` is the drive of maximum first-order
   diffraction, exactly as the paper defines the normalised amplitude.
2. **Bragg diffraction** (thick grating, small-signal coupled-mode solution):
   first-order efficiency ``eta(A) = eta_ref sin^2(pi u / 2)``; the optical
   field amplitude is ``sqrt(eta)``.  Normalised to unit slope at the origin
   (paper, Methods) it is

   .. math:: y(A) = \\frac{\\sin(\\pi u(A)/2)}{(\\pi/2)\\,u'(0)},\\qquad
             A_\\mathrm{corr} = y(1) = \\frac{2}{\\pi u'(0)}.

   The gain ``g`` is solved from the requested ``A_corr`` (0.5655 in the
   paper, Supplement S2).
3. **Amplitude-to-phase conversion** from the power dependence of the acoustic
   velocity (Supplement S1): the optical phase follows the acoustic power,
   ``phi(A) = phi_1 u(A)^2`` rad, with ``phi_1 = phi(1) = 0.2776`` rad.

Detection models (photodiode power with background subtraction, heterodyne
phase with weak-signal degradation) generate calibration *recordings*; see
:func:`simulate_amplitude_run` and :func:`simulate_phase_run`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.optimize import brentq

from dpdfit.core.defaults import ETA_REF
from dpdfit.models.transfer import TransferFunction

__all__ = ["A_CORR", "PHI_1", "BraggAOM", "PhotodiodeNoise", "HeterodyneNoise",
           "simulate_amplitude_run", "simulate_phase_run", "ou_series", "truth_poly_tf"]

#: Maximum correctable amplitude ``y(1)`` of the paper's AOM (Supplement S2).
A_CORR = 0.5655
#: Optical phase shift at full drive [rad] of the paper's AOM (Supplement S1).
PHI_1 = 0.2776


@dataclass(frozen=True)
class BraggAOM:
    """Bragg-regime AOM driven through a compressing RF amplifier.

    Parameters
    ----------
    A_corr : float
        Target maximum correctable amplitude ``y(1)`` (unit-slope normalised),
        0 < A_corr < 2/pi.  Sets the amplifier compression.
    phi_1 : float
        Optical phase shift at full drive, rad.
    eta_ref : float
        Peak first-order diffraction efficiency at ``A = 1``.
    rf_gain : float
        The RF drive reaching the crystal per unit of normalised amplitude, relative to
        the amplifier that ``A_corr`` describes (1: that one).  A drifting RF gain (an
        amplifier, a cable, a connector warming up) scales the drive ahead of the
        compression, ``u(A) = tanh(g rf_gain A)/tanh(g)``: the pi/2 point moves away from
        ``A = 1`` and the curve changes in another shape than a change of ``A_corr``.
        The field's unit is kept (``y`` has slope ``rf_gain`` at the origin).

    Notes
    -----
    The model is memoryless; a memory of the modulator is injected as the
    effect ``aom_memory`` (its injection's ``inject_drive`` hook,
    :mod:`dpdfit.simulation.injections.aom_memory`, applied by the campaign
    simulator before :meth:`field`).
    """

    A_corr: float = A_CORR
    phi_1: float = PHI_1
    eta_ref: float = ETA_REF
    rf_gain: float = 1.0
    g: float = field(init=False)

    def __post_init__(self):
        if not 0 < self.A_corr < 2 / np.pi:
            raise ValueError("A_corr must lie in (0, 2/pi) for a compressing amplifier")
        if not (np.isfinite(self.rf_gain) and self.rf_gain > 0):
            raise ValueError(f"rf_gain must be finite and > 0, got {self.rf_gain}")
        c = 2.0 / (np.pi * self.A_corr)          # required u'(0)
        g = brentq(lambda g: g / np.tanh(g) - c, 1e-6, 50.0, xtol=1e-15, rtol=1e-15)
        object.__setattr__(self, "g", g)

    def u(self, A):
        """Acoustic amplitude normalised to the Bragg pi/2 point (u(1) = 1)."""
        # (g rf_gain) A: exactly g A at rf_gain = 1
        return np.tanh((self.g * self.rf_gain) * np.asarray(A, dtype=float)) / np.tanh(self.g)

    @property
    def slope0(self) -> float:
        """u'(0), the small-signal amplifier gain relative to the pi/2 drive."""
        return self.g / np.tanh(self.g)

    def y(self, A):
        """Optical field amplitude normalised to unit slope at A = 0."""
        return np.sin(0.5 * np.pi * self.u(A)) / (0.5 * np.pi * self.slope0)

    def efficiency(self, A):
        """First-order diffraction efficiency eta(A) (fraction of input power)."""
        return self.eta_ref * np.sin(0.5 * np.pi * self.u(A)) ** 2

    def phase(self, A):
        """Amplitude-to-phase conversion phi(A), rad."""
        return self.phi_1 * self.u(A) ** 2

    def field(self, x):
        """Optical field for a (complex) RF envelope ``x`` (``|x| = A``), normalised like y.

        Same form as the paper's Eq. S11 but with the physical
        transfer functions; drive beyond ``|x| = 1`` is *not* clipped (the
        Bragg efficiency rolls over).
        """
        x = np.asarray(x)
        mag = np.abs(x)
        theta = np.angle(x)
        return self.y(mag) * np.exp(1j * (theta + self.phase(mag)))

    @property
    def true_A_corr(self) -> float:
        """y(1), the exact maximum correctable amplitude."""
        return float(self.y(1.0))

    @property
    def measured_A_corr(self) -> float:
        """``y(1)`` over the field's slope at ``A = 0``: the ``A_corr`` a calibration run
        (normalised to unit slope at the origin) measures; ``true_A_corr`` unless the RF
        gain drifted."""
        return float(self.y(1.0)) / self.rf_gain

    @property
    def true_phi_1(self) -> float:
        """phi(1), rad."""
        return float(self.phase(1.0))


@dataclass(frozen=True)
class PhotodiodeNoise:
    """Integrated photodiode signal with background subtraction.

    The recorded ``power`` is ``p_full * eta(A)/eta_ref`` plus Gaussian noise
    of standard deviation ``sqrt(sigma_0**2 + (rel * P)**2)``: ``sigma_0`` is
    the detector/ADC noise of the integrated signal *after* subtracting an
    independently measured background (so it is present at A = 0 and makes
    the smallest powers scatter around zero, sometimes below it), ``rel`` the
    relative laser-intensity noise.  ``power_err`` reports this model's sigma.
    """

    p_full: float = 2.0
    sigma_0: float = 5.0e-4
    rel: float = 1.0e-3

    def sigma(self, p_true):
        """1-sigma noise of the recorded power at true power ``p_true``,
        ``sqrt(sigma_0^2 + (rel p_true)^2)``."""
        return np.sqrt(self.sigma_0 ** 2 + (self.rel * np.asarray(p_true)) ** 2)


@dataclass(frozen=True)
class HeterodyneNoise:
    """I/Q-demodulated heterodyne phase measurement.

    The demodulated phasor is ``s(A) e^{i phi(A)} + leak + n``, with
    ``s = sqrt(eta/eta_ref)`` the beat amplitude relative to full drive,
    ``n`` complex Gaussian noise of per-quadrature std ``sigma_iq`` and a
    small constant RF/optical ``leak`` phasor, so the phase noise grows as
    ``sigma_iq / s``.  Below ``s_lock`` (A ~ 0.1 for the default AOM) the
    demodulator no longer tracks the weak beat and its noise grows by the
    factor ``excess``; the recorded ``phase_err`` (``sigma_iq / s``) does not
    know this.  That is why the phase is unreliable below A = 0.1 and the
    paper fits only ``A >= 0.1`` (Supplement S1).
    """

    sigma_iq: float = 1.0e-3
    leak: complex = 3.0e-5 * np.exp(1j * 1.0)
    s_lock: float = 0.17
    excess: float = 10.0


def simulate_amplitude_run(aom: BraggAOM, A, rng: np.random.Generator,
                           noise: PhotodiodeNoise = PhotodiodeNoise()) -> pd.DataFrame:
    """One amplitude-calibration run: columns ``A, power, power_err``."""
    A = np.asarray(A, dtype=float)
    p_true = noise.p_full * aom.efficiency(A) / aom.eta_ref
    sig = noise.sigma(p_true)
    power = p_true + sig * rng.standard_normal(A.shape)
    return pd.DataFrame({"A": A, "power": power, "power_err": sig})


def simulate_phase_run(aom: BraggAOM, A, rng: np.random.Generator,
                       noise: HeterodyneNoise = HeterodyneNoise()) -> pd.DataFrame:
    """One phase-calibration run: columns ``A, phase_rad, phase_err``."""
    A = np.asarray(A, dtype=float)
    s = np.sqrt(aom.efficiency(A) / aom.eta_ref)
    sig = noise.sigma_iq * np.where(s < noise.s_lock, noise.excess, 1.0)
    z = (s * np.exp(1j * aom.phase(A)) + noise.leak
         + sig * (rng.standard_normal(A.shape) + 1j * rng.standard_normal(A.shape)))
    # phase relative to the weak-drive limit; the experiment references the
    # phase to the reference beam, an overall constant removed at A -> 0
    phase = np.angle(z)
    with np.errstate(divide="ignore"):
        err = np.where(s > 0, noise.sigma_iq / np.maximum(s, 1e-300), np.pi)
    return pd.DataFrame({"A": A, "phase_rad": phase, "phase_err": np.minimum(err, np.pi)})


def ou_series(times, sigma: float, tau: float, rng: np.random.Generator) -> np.ndarray:
    """Stationary Ornstein-Uhlenbeck process sampled at (irregular) ``times``.

    Zero mean, standard deviation ``sigma``, correlation time ``tau`` (same
    units as ``times``): ``x_{k+1} = x_k e^{-dt/tau} + sigma sqrt(1 - e^{-2 dt/tau}) N(0,1)``.
    Used for run-to-run drift of the AOM's transfer function (Supplement S2).
    """
    t = np.asarray(times, dtype=float)
    x = np.empty(t.size)
    x[0] = sigma * rng.standard_normal()
    for k in range(1, t.size):
        a = np.exp(-(t[k] - t[k - 1]) / tau)
        x[k] = a * x[k - 1] + sigma * np.sqrt(1 - a * a) * rng.standard_normal()
    return x


def truth_poly_tf(K=8, with_phase=True):
    """The truth AOM's transfer function in the polynomial form dpdfit fits.

    Least-squares polynomials (powers ``1..K`` for the amplitude, normalised to unit
    slope, and ``1..5`` for the phase) that approximate :class:`BraggAOM` closely on
    ``A`` in [0, 1]: the truth behind a sweep or a simulated gate when a test or a
    benchmark needs one without fitting a calibration first.
    """
    aom = BraggAOM()
    A = np.linspace(0, 1, 400)
    V = A[:, None] ** np.arange(1, K + 1)
    a, *_ = np.linalg.lstsq(V, aom.y(A), rcond=None)
    a = a / a[0]
    if with_phase:
        b, *_ = np.linalg.lstsq(V[:, :5], aom.phase(A), rcond=None)
        return TransferFunction(range(1, K + 1), a, range(1, 6), b)
    return TransferFunction(range(1, K + 1), a)
