"""Multi-tone gate waveforms (Supplement S3) and their predistortion.

A tone set lists tones by harmonic index ``n`` (detuning ``n * xi0`` from the
motional sideband), signed amplitude ``r`` and phase ``phi`` (rad) on the blue
(``+nu + n xi0``) and red (``-nu - n xi0``) sidebands.  The RF envelope in the
rotating frame of the carrier is (Supplement Eq. S2)::

    w(t) = w_I + i w_Q = sum_j r_j exp(i (2 pi f_j t + phi_j)),
    f_j = +(nu + n_j xi0) (blue)  or  -(nu + n_j xi0) (red),

normalised so that ``max_t |w(t)| = A``.  For Cardioid(1,2) (``r_1 = +1``,
``r_2 = -1`` on both sidebands, all phases 0) the red and blue tones pair up
into ``2 r cos(...)``: the envelope is real (``w_Q = 0``).

Sampling grid
-------------
:func:`sample_grid` chooses the record length and sample rate so that

* every tone, and every mixing product of the tones, falls exactly on an FFT
  bin: the record spans an integer number of gate periods ``P / xi0`` such
  that ``nu * P / xi0`` is an integer (``nu / xi0`` must be a ratio of small
  integers, which is refused with the reason otherwise);
* products up to order 9 are not aliased: the complex sample rate exceeds
  ``2 * 9 * f_max``, ``f_max`` the largest tone frequency, so every product
  ``sum of 9 tone frequencies`` lies inside ``(-fs/2, fs/2)``.

A user-chosen sample rate or length that violates either is refused.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np
from scipy.fft import next_fast_len

from dpdfit.errors import InputError

__all__ = ["ToneSet", "cardioid", "Grid", "sample_grid", "synthesize", "predistort",
           "MAX_PRODUCT_ORDER", "drive_peak"]

#: Mixing products up to this order must not alias (see "Sampling grid" above).
MAX_PRODUCT_ORDER = 9


@dataclass(frozen=True)
class ToneSet:
    """A set of drive tones on both sidebands.

    Attributes
    ----------
    n : tuple of int
        Harmonic indices (detuning ``n * xi0`` from the motional sideband).
    r_blue, r_red : tuple of float
        Signed relative amplitudes on the blue and red sideband.
    phi_blue, phi_red : tuple of float
        Phases, rad.
    name : str
        Label (e.g. "Cardioid(1,2)").
    """

    n: tuple
    r_blue: tuple
    r_red: tuple
    phi_blue: tuple = None
    phi_red: tuple = None
    name: str = "tones"

    def __post_init__(self):
        k = len(self.n)
        set_ = object.__setattr__
        set_(self, "n", tuple(int(v) for v in self.n))
        set_(self, "r_blue", tuple(float(v) for v in self.r_blue))
        set_(self, "r_red", tuple(float(v) for v in self.r_red))
        set_(self, "phi_blue", tuple(float(v) for v in (self.phi_blue or (0.0,) * k)))
        set_(self, "phi_red", tuple(float(v) for v in (self.phi_red or (0.0,) * k)))
        if k == 0:
            raise InputError("a tone set needs at least one tone")
        if not (len(self.r_blue) == len(self.r_red) == len(self.phi_blue)
                == len(self.phi_red) == k):
            raise InputError("tone set: n, amplitudes and phases must have equal lengths")
        if len(set(self.n)) != k:
            raise InputError(f"tone set: harmonic indices must be distinct, got {self.n}")
        if not np.all(np.isfinite(self.r_blue + self.r_red + self.phi_blue + self.phi_red)):
            raise InputError("tone set: amplitudes and phases must be finite")

    @property
    def symmetric(self) -> bool:
        """Red and blue identical (the paper's double-sideband encoding)."""
        return self.r_blue == self.r_red and self.phi_blue == self.phi_red

    def frequencies(self, nu: float, xi0: float) -> tuple[np.ndarray, np.ndarray]:
        """Baseband frequencies (Hz) of the blue and red tones."""
        n = np.asarray(self.n, dtype=float)
        return nu + n * xi0, -(nu + n * xi0)


def cardioid(n: int = 1, m: int = 2) -> ToneSet:
    """Cardioid(n, m) tone set (S3): ``r_n = +1``, ``r_m = -1`` on both sidebands."""
    if n == m or n < 1 or m < 1:
        raise InputError(f"Cardioid(n, m) needs distinct positive n, m, got ({n}, {m})")
    return ToneSet((n, m), (1.0, -1.0), (1.0, -1.0), name=f"Cardioid({n},{m})")


@dataclass(frozen=True)
class Grid:
    """Sampling grid of one simulated record.

    Attributes
    ----------
    fs : float
        Complex sample rate, Hz.
    n_samples : int
    periods : int
        Record length in gate periods ``1/xi0``.
    nu, xi0 : float
        Sideband and gate detunings, Hz.
    """

    fs: float
    n_samples: int
    periods: int
    nu: float
    xi0: float
    _nu_bins: int = field(default=0, repr=False)

    @property
    def duration(self) -> float:
        """Record length in seconds, ``n_samples / fs``."""
        return self.n_samples / self.fs

    @property
    def t(self) -> np.ndarray:
        """Sample times in seconds, ``0, 1/fs, ..., (n_samples - 1)/fs``."""
        return np.arange(self.n_samples) / self.fs

    def bin(self, freq_hz):
        """FFT bin index (``numpy.fft`` order) of exact grid frequencies."""
        k = np.rint(np.asarray(freq_hz) * self.duration).astype(int)
        return np.mod(k, self.n_samples)

    def tone_bins(self, harmonics) -> tuple[np.ndarray, np.ndarray]:
        """Bins of ``+/-(nu + n xi0)`` for the requested harmonics (blue, red)."""
        n = np.asarray(harmonics, dtype=int)
        k = self._nu_bins + n * self.periods
        return np.mod(k, self.n_samples), np.mod(-k, self.n_samples)


def _commensurate(nu: float, xi0: float, max_periods: int) -> int:
    """Smallest number of gate periods P with nu * P / xi0 an integer."""
    ratio = Fraction(nu / xi0).limit_denominator(max_periods)
    if abs(float(ratio) - nu / xi0) > 1e-9 * max(1.0, nu / xi0):
        raise InputError(
            f"nu/xi0 = {nu / xi0:.12g} is not a ratio of integers with denominator <= "
            f"{max_periods}: no finite record puts every tone exactly on an FFT bin; "
            f"choose nu as a multiple of xi0/{max_periods} (e.g. nu = "
            f"{round(nu / xi0) * xi0:.6g} Hz)")
    return ratio.denominator


def sample_grid(nu: float, xi0: float, tones: ToneSet, *, fs: float | None = None,
                periods: int | None = None, max_periods: int = 64,
                extra_harmonics=(0, 3)) -> Grid:
    """Choose (or check) the sampling grid of a simulated record.

    Parameters
    ----------
    nu, xi0 : float
        Motional sideband and gate detunings, Hz (both > 0).
    tones : ToneSet
        The drive tones.
    fs : float, optional
        Requested complex sample rate, Hz; must be an integer multiple of
        ``xi0 / periods`` and exceed ``2 * 9 * f_max``.  Default: the smallest
        FFT-friendly rate that satisfies both.
    periods : int, optional
        Record length in gate periods; must make ``nu * periods / xi0`` an
        integer.  Default: the smallest such number.
    extra_harmonics : iterable of int
        Harmonic indices that will be read from the spectrum (IM products);
        they must fall inside the band too.
    """
    if not (np.isfinite(nu) and np.isfinite(xi0) and nu > 0 and xi0 > 0):
        raise InputError(f"nu and xi0 must be positive, got nu={nu}, xi0={xi0}")
    p_min = _commensurate(nu, xi0, max_periods)
    if periods is None:
        periods = p_min
    elif periods < 1 or abs(periods * nu / xi0 - round(periods * nu / xi0)) > 1e-6:
        raise InputError(f"{periods} gate periods do not put nu = {nu:g} Hz on an FFT bin "
                         f"(nu * periods / xi0 = {periods * nu / xi0:.9g}); use a multiple of "
                         f"{p_min}")
    n_all = np.asarray(tuple(tones.n) + tuple(extra_harmonics))
    f_max = float(np.max(np.abs(nu + n_all * xi0)))
    fs_min = 2 * MAX_PRODUCT_ORDER * f_max
    T = periods / xi0
    if fs is None:
        n_samples = next_fast_len(int(np.floor(fs_min * T)) + 1)
        fs = n_samples / T
    else:
        n_samples = fs * T
        if abs(n_samples - round(n_samples)) > 1e-6:
            raise InputError(f"sample rate {fs:g} Hz does not give an integer number of samples "
                             f"per record of {periods} gate period(s) ({n_samples:.6f})")
        n_samples = int(round(n_samples))
        if fs <= fs_min:
            raise InputError(
                f"sample rate {fs:g} Hz aliases mixing products: order-{MAX_PRODUCT_ORDER} "
                f"products of tones up to {f_max:g} Hz reach {MAX_PRODUCT_ORDER * f_max:g} Hz, "
                f"so fs must exceed {fs_min:g} Hz")
    return Grid(fs=float(fs), n_samples=int(n_samples), periods=int(periods), nu=float(nu),
                xi0=float(xi0), _nu_bins=int(round(nu * T)))


def synthesize(tones: ToneSet, grid: Grid, A) -> np.ndarray:
    """RF envelope samples for peak amplitude(s) ``A`` (Eqs. S2-S3, max|w| = A).

    Parameters
    ----------
    tones : ToneSet
    grid : Grid
    A : float or array_like
        Target peak amplitude(s); a batch gives shape ``(len(A), n_samples)``.

    Returns
    -------
    ndarray
        Real if the tone set is symmetric (``w_Q = 0``, S3), else complex.
    """
    w = _envelope(tones, grid, grid.t)
    peak = drive_peak(tones, grid)
    A = np.asarray(A, dtype=float)
    if np.any((A < 0) | (A > 1)) or not np.all(np.isfinite(A)):
        raise InputError("amplitudes A must lie in [0, 1]")
    return (A[..., None] if A.ndim else A) * (w / peak)


def drive_peak(tones: ToneSet, grid: Grid) -> float:
    """Peak of the continuous drive envelope (what the DAC's reconstructed output
    reaches; ``synthesize`` normalises it to A), found on a 16x finer grid of the record."""
    t = np.arange(16 * grid.n_samples) / (16 * grid.fs)
    return float(np.max(np.abs(_envelope(tones, grid, t))))


def _envelope(tones: ToneSet, grid: Grid, t: np.ndarray) -> np.ndarray:
    f_b, f_r = tones.frequencies(grid.nu, grid.xi0)
    w = np.zeros(t.shape, dtype=complex)
    for fb, fr, rb, rr, pb, pr in zip(f_b, f_r, tones.r_blue, tones.r_red, tones.phi_blue,
                                      tones.phi_red):
        w += rb * np.exp(1j * (2 * np.pi * fb * t + pb))
        w += rr * np.exp(1j * (2 * np.pi * fr * t + pr))
    if tones.symmetric and np.all(np.asarray(tones.phi_blue) == 0):
        w = w.real.copy()                 # exactly real, as the AWG drives it (S3)
    return w


def predistort(w, transfer) -> np.ndarray:
    """Apply DPD sample by sample (S3): ``|x| = f_AM^{-1}(|w|)``, phase kept.

    ``transfer`` is a :class:`dpdfit.models.transfer.TransferFunction`; samples with
    ``|w| >= A_corr`` are clamped to full drive.
    """
    w = np.asarray(w)
    if np.iscomplexobj(w):
        mag = np.abs(w)
        return transfer.inverse_am(mag) * np.exp(1j * np.angle(w))
    return transfer.inverse_am(w)
