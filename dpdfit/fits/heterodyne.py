"""Tone powers from a recorded heterodyne photodiode trace (Supplement S4).

The gate beam, carrying a multi-tone waveform, is beaten against a reference
beam offset by ``f_det`` (~20 MHz) on a fast photodiode and digitised (e.g.
``fs = 1 GS/s`` for ~2 ms).  The gate tone at detuning ``n * xi0`` from the
motional sideband ``nu`` appears at ::

    blue group:  f_det + (nu + n xi0)
    red group:   f_det - (nu + n xi0)

(``swap_sidebands=True`` exchanges the two groups, for a reference beam offset
the other way).  Harmonics ``n = 1, 2`` are the Cardioid(1, 2) gate tones;
``n = 0`` and ``n = 3`` are third-order intermodulation (IM3) products, and
any other ``n`` (e.g. IM5 at ``n = -1`` and ``n = 4``) can be requested.

Procedure (:func:`trace_tone_powers`)
-------------------------------------
1. **Spectrum.**  The power spectrum is the flat-top periodogram
   ``scipy.signal.periodogram(trace, fs, window="flattop",
   scaling="spectrum")`` (default ``detrend="constant"``, one-sided), so that
   a sinusoid ``a cos(2 pi f t + p)`` reads ``a**2 / 2`` at its peak bin to
   within the flat-top scalloping loss (< 0.01 dB at any position between
   bins).  It is computed by :func:`flattop_periodogram`, which gives the
   same numbers (to ~1e-11 relative, asserted in the tests) about 7x faster
   for 2^21 samples (``benchmarks/heterodyne_speed.py``): scipy 1.17's
   ``periodogram`` runs through ``ShortTimeFFT``, generates the 2^21-point
   window (4 cosines per sample) and sums it with a Python-level ``sum``,
   which together take several times the FFT.  The periodic flat-top window
   is a 5-term cosine sum, so windowing is a 9-tap convolution of the plain
   ``rfft`` and the constant detrend is zeroing the DC bin -- both exact
   identities of the discrete Fourier transform -- and only the bins of the
   detection band are formed.
2. **dB reference.**  ``P_dB = 10 log10(2 * S)`` where ``S`` is the
   'spectrum' periodogram value: 0 dB is a sinusoid of unit *peak*
   amplitude in the trace's units, i.e. ``a cos(2 pi f t + p)`` reads
   ``20 log10(a)`` dB.
3. **Noise floor.**  The median of the periodogram over the detection band
   ``f_det +/- (max_n |nu + n xi0| + 2 xi0)`` (two harmonic spacings beyond
   the outermost requested tone, clipped to the spectrum), leaving out the
   bins within ``search_hz + 5 bins`` of every requested tone.  The median is
   insensitive to the few remaining (unrequested) tones.  For white Gaussian
   noise each bin's power is exponentially distributed, so the *mean* noise
   power per bin is ``noise_floor / ln 2`` (+1.59 dB); the reported floor is
   the median.  ``snr_db = P_dB - noise_floor_dB``.
4. **Gate tones** (``n`` in ``gate``): the peak (largest bin) within
   ``+/- search_hz`` of the expected frequency.  Its frequency is refined to
   the power-weighted centroid of the main lobe (peak bin +/- 5 bins; exact
   for an isolated noise-free tone because the flat-top main lobe is
   compact), and ``P_dB`` is read at the bin nearest to that frequency.
   The tone is valid if ``|found - expected| < max_freq_error_hz`` (1 kHz)
   **and** ``snr_db > min_snr_db`` (20 dB); otherwise ``valid`` is False and
   ``reason`` says which test failed.
5. **IM tones** (other ``n``): read at the bin nearest to the expected
   frequency, without peak search (the flat main lobe makes that accurate).
   An IM tone with ``snr_db < im_min_snr_db`` (10 dB) is flagged
   ``valid=False``, ``reason="at noise floor: upper limit"``: its ``P_dB`` is
   then (statistically) an upper limit.  The 10 dB threshold: a noise-only
   bin exceeds the median by 10 dB with probability ``2**-10 ~ 1e-3`` (3 dB
   would be exceeded by a quarter of all noise bins).  A read-out includes
   the noise power of its bin (+0.6 dB bias at 10 dB SNR, negligible above
   ~25 dB).
6. **Ratios** per sideband ``R10 = P1_dB - P0_dB`` and
   ``R23 = P2_dB - P3_dB``; ``None`` if a harmonic was not requested or a
   gate tone is invalid.  A noise-limited IM tone in the denominator makes
   the ratio a lower limit (``R10_limit = "lower"``; in the numerator
   ``"upper"``; both noise-limited -> ``None``).  The top-level ``R10_dB``,
   ``R23_dB`` are the mean of the two sidebands' dB values (as the paper),
   ``None`` if either is ``None`` or the two are limits in opposite
   directions; a limit on either side makes the mean the same kind of limit.

Requirements checked before any analysis (:class:`~dpdfit.errors.InputError`)
------------------------------------------------------------------------------
* **Resolution.**  The main lobe of the flat-top window extends +/-5 bins
  (its first nulls; it is a 5-term cosine sum).  Tones ``xi0`` apart must
  not overlap: ``5 * fs / N < xi0 / 2``, i.e. the trace must be longer than
  ``10 / xi0`` (0.5 ms for ``xi0 = 20 kHz``).
* **Margins.**  With ``margin = max(search_hz, 5 bins) + 5 bins`` (a search
  window plus a main lobe): every requested tone must lie more than
  ``margin`` above 0 Hz (red tones at negative frequency fold over) and below
  ``fs/2`` (Nyquist), and any two requested tones, in either group, must be
  more than ``margin`` apart (otherwise one tone's main lobe lies in another
  tone's search window, or a red tone lands on a blue one).

Dynamic range: the flat-top sidelobes are at about -93 dB (-100 dB at 60
bins), so an IM tone more than ~70 dB below the gate tones is affected by
their leakage at the 0.1 dB level.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
import scipy.fft

from dpdfit.recordings.outputs import atomic_write_json, refuse_overwriting_inputs, to_jsonable
from dpdfit.errors import InputError

__all__ = ["trace_tone_powers", "TraceSpectrum", "SidebandTones", "ToneMap",
           "flattop_periodogram", "simulate_beat_trace", "load_trace",
           "add_spectrum_command", "cmd_spectrum", "FLATTOP_COEFFICIENTS",
           "MAIN_LOBE_BINS", "NOISE_BAND_MARGIN", "AT_NOISE_FLOOR"]

#: Coefficients ``a_k`` of ``scipy.signal.windows.flattop`` (D'Antonio);
#: the periodic window is ``w[n] = sum_k (-1)**k a_k cos(2 pi k n / N)``.
FLATTOP_COEFFICIENTS = (0.21557895, 0.41663158, 0.277263158, 0.083578947, 0.006947368)
#: Half-width of the flat-top main lobe in bins (first nulls at +/-5 bins).
MAIN_LOBE_BINS = 5
#: The noise-floor band extends this many harmonic spacings xi0 beyond the
#: outermost requested tone.
NOISE_BAND_MARGIN = 2
#: ``reason`` of an IM tone whose power is within ``im_min_snr_db`` of the floor.
AT_NOISE_FLOOR = "at noise floor: upper limit"

_SIDEBANDS = ("red", "blue")


# ----------------------------------------------------------------------------- helpers


class ToneMap(Mapping):
    """Read-only mapping harmonic number ``n`` (int) -> value."""

    __slots__ = ("_d",)

    def __init__(self, items=()):
        self._d = dict(items)

    def __getitem__(self, n):
        return self._d[n]

    def __iter__(self):
        return iter(self._d)

    def __len__(self):
        return len(self._d)

    def __repr__(self):
        return f"ToneMap({self._d!r})"


def _fnum(value, name: str, *, positive: bool = True) -> float:
    """A finite (positive) float parameter, or InputError naming it."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise InputError(f"{name} must be finite, got {v}")
    if positive and v <= 0:
        raise InputError(f"{name} must be > 0, got {v:g}")
    return v


def _hz(f: float) -> str:
    """Compact frequency with unit (for messages)."""
    a = abs(f)
    if a >= 1e9:
        return f"{f / 1e9:.6g} GHz"
    if a >= 1e6:
        return f"{f / 1e6:.7g} MHz"
    if a >= 1e3:
        return f"{f / 1e3:.6g} kHz"
    return f"{f:.4g} Hz"


def _as_trace(trace, *, file: str | None = None) -> np.ndarray:
    """1-D finite float64 samples, or InputError (row = 1-based sample number)."""
    arr = np.asarray(trace)
    if arr.ndim == 2 and arr.shape[1] == 1:
        arr = arr[:, 0]
    if arr.ndim != 1:
        raise InputError(f"trace must be a 1-D array of samples, got shape {arr.shape}",
                         file=file)
    if arr.dtype.kind == "c":
        raise InputError("trace is complex; expected the real photodiode samples", file=file)
    if arr.dtype.kind not in "iuf":
        raise InputError(f"trace must hold real numbers, got dtype {arr.dtype}", file=file)
    if arr.size == 0:
        raise InputError("trace contains no samples", file=file)
    x = np.asarray(arr, dtype=np.float64)   # float32/int16 -> float64 (never compute in single)
    if not np.isfinite(x).all():
        i = int(np.flatnonzero(~np.isfinite(x))[0])
        raise InputError(f"sample is {x[i]} (must be finite)", file=file, row=i + 1)
    return x


def _harmonics(values, name: str) -> tuple[int, ...]:
    try:
        vals = list(values)
    except TypeError:
        raise InputError(f"{name} must be a sequence of integers, got {values!r}") from None
    out = []
    for v in vals:
        try:
            ok = not isinstance(v, (bool, np.bool_)) and float(v).is_integer()
        except (TypeError, ValueError, OverflowError):
            ok = False
        if not ok:
            raise InputError(f"{name}: {v!r} is not an integer harmonic number")
        out.append(int(float(v)))
    if len(set(out)) != len(out):
        raise InputError(f"{name} lists a harmonic more than once: {out}")
    return tuple(sorted(out))


# ----------------------------------------------------------------------------- periodogram


def _band_psd(X: np.ndarray, n: int, k_lo: int, k_hi: int) -> np.ndarray:
    """'spectrum'-scaled one-sided flat-top periodogram on bins ``k_lo..k_hi``.

    ``X = rfft(x)`` of the ``n`` raw samples.  Windowing by the periodic
    flat-top (a 5-term cosine sum) is the 9-tap convolution
    ``Y[m] = a0 X[m] + sum_k (-1)^k a_k / 2 (X[m-k] + X[m+k])``, and the
    constant detrend sets ``X[0] = 0``; indices outside ``0..n//2`` follow from
    ``X[-j] = X[n-j] = conj(X[j])``.  ``sum(w) = n a0``.
    """
    taps = len(FLATTOP_COEFFICIENTS) - 1
    idx = np.arange(k_lo - taps, k_hi + taps + 1)
    j = np.mod(idx, n)
    mirror = j > n // 2
    j = np.where(mirror, n - j, j)
    Xg = X[j]
    Xg[mirror] = np.conj(Xg[mirror])
    Xg[j == 0] = 0.0                                   # detrend="constant"
    m = Xg.size - 2 * taps
    a = FLATTOP_COEFFICIENTS
    Y = a[0] * Xg[taps:taps + m]
    for k in range(1, taps + 1):
        Y = Y + ((-1) ** k * a[k] / 2) * (Xg[taps - k:taps - k + m] + Xg[taps + k:taps + k + m])
    P = (Y.real * Y.real + Y.imag * Y.imag) / (n * a[0]) ** 2
    k = np.arange(k_lo, k_hi + 1)
    one_sided = (k > 0) & ~((n % 2 == 0) & (k == n // 2))
    P[one_sided] *= 2.0
    return P


def flattop_periodogram(trace, fs: float, f_lo: float | None = None,
                        f_hi: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Flat-top power spectrum of a real trace, optionally on a band only.

    Identical (to rounding) to ``scipy.signal.periodogram(trace, fs,
    window="flattop", scaling="spectrum")`` on the returned bins, computed as
    one ``rfft`` plus a 9-tap convolution per returned bin (see
    :func:`_band_psd`).

    Parameters
    ----------
    trace : array_like, shape (N,)
        Real samples (any units; converted to float64).
    fs : float
        Sample rate, Hz.
    f_lo, f_hi : float, optional
        Return only the bins with ``f_lo <= f <= f_hi`` (Hz); default: all
        ``N // 2 + 1`` bins.

    Returns
    -------
    freqs : ndarray
        Bin frequencies ``k * fs / N``, Hz.
    psd : ndarray
        Power per bin in (trace units)^2; a sinusoid of peak amplitude ``a``
        reads ``a**2 / 2``.
    """
    fs = _fnum(fs, "fs")
    x = _as_trace(trace)
    n = x.size
    df = fs / n
    last = n // 2
    k_lo = 0 if f_lo is None else max(0, math.ceil(f_lo / df - 1e-9))
    k_hi = last if f_hi is None else min(last, math.floor(f_hi / df + 1e-9))
    if k_hi < k_lo:
        return np.empty(0), np.empty(0)
    X = scipy.fft.rfft(x)
    return np.arange(k_lo, k_hi + 1) * df, _band_psd(X, n, k_lo, k_hi)


# ----------------------------------------------------------------------------- results


@dataclass(frozen=True)
class SidebandTones:
    """Tones of one sideband group ('red' or 'blue') of the beat spectrum.

    All maps are keyed by the harmonic number ``n`` (int).

    Attributes
    ----------
    name : {"red", "blue"}
    sign : int
        ``+1`` or ``-1``: the tones are at ``f_det + sign * (nu + n xi0)``.
    role : ToneMap of str
        ``"gate"`` (peak search and validation) or ``"IM"`` (read at the
        expected frequency).
    expected_hz : ToneMap of float
        Expected beat frequency, Hz.
    found_hz : ToneMap of float
        Gate tones: refined peak frequency (main-lobe centroid), Hz.  IM
        tones: the frequency of the bin that was read, Hz.
    freq_error_hz : ToneMap of float or None
        ``found - expected`` for gate tones, Hz; ``None`` for IM tones.
    P_dB : ToneMap of float
        Tone power, dB re a sinusoid of unit peak amplitude (trace units).
        Reported for every tone, valid or not.
    snr_db : ToneMap of float
        ``P_dB - noise_floor_dB``.
    valid : ToneMap of bool
    reason : ToneMap of str
        ``"ok"`` or why the tone is not valid.
    R10_dB, R23_dB : float or None
        ``P1_dB - P0_dB`` and ``P2_dB - P3_dB``.
    R10_limit, R23_limit : {None, "lower", "upper"}
        Whether the ratio is only a bound (a noise-limited IM tone).
    """

    name: str
    sign: int
    role: ToneMap
    expected_hz: ToneMap
    found_hz: ToneMap
    freq_error_hz: ToneMap
    P_dB: ToneMap
    snr_db: ToneMap
    valid: ToneMap
    reason: ToneMap
    R10_dB: float | None
    R23_dB: float | None
    R10_limit: str | None
    R23_limit: str | None

    def to_dict(self) -> dict:
        """Plain-python copy; maps keyed by the harmonic number as a string."""
        def m(tm):
            return {str(n): v for n, v in tm.items()}
        return {
            "P_dB": m(self.P_dB), "valid": m(self.valid),
            "R10_dB": self.R10_dB, "R23_dB": self.R23_dB,
            "R10_limit": self.R10_limit, "R23_limit": self.R23_limit,
            "reason": m(self.reason), "snr_db": m(self.snr_db), "role": m(self.role),
            "expected_hz": m(self.expected_hz), "found_hz": m(self.found_hz),
            "freq_error_hz": m(self.freq_error_hz), "sign": self.sign,
        }


@dataclass(frozen=True)
class TraceSpectrum:
    """Tone powers of a heterodyne trace (result of :func:`trace_tone_powers`).

    Attributes
    ----------
    red, blue : SidebandTones
        The two sideband groups.
    R10_dB, R23_dB : float or None
        Mean over the two sidebands of their dB ratios (``None`` if either
        is ``None``).  ``R10_limit``, ``R23_limit``: ``None`` (a measurement),
        ``"lower"`` or ``"upper"`` (a bound).
    noise_floor_dB : float
        Median of the periodogram over ``noise_band_hz`` (requested tones
        excluded), in the dB reference of ``P_dB``.
    noise_band_hz : tuple of float
        The band of the noise-floor median, Hz.
    n_noise_bins : int
        Number of bins in the median.
    resolution_hz : float
        Bin spacing ``fs / N``, Hz.  The flat-top main lobe spans +/-5 bins,
        its noise-equivalent bandwidth is ``enbw_hz`` (3.77 bins).
    fs, f_det, nu, xi0 : float
        Sample rate and the beat-frequency parameters, Hz.
    n_samples : int
    harmonics, gate : tuple of int
    search_hz, max_freq_error_hz, min_snr_db, im_min_snr_db : float
        The validation thresholds used.
    swap_sidebands : bool
    """

    red: SidebandTones
    blue: SidebandTones
    R10_dB: float | None
    R23_dB: float | None
    R10_limit: str | None
    R23_limit: str | None
    noise_floor_dB: float
    noise_band_hz: tuple
    n_noise_bins: int
    resolution_hz: float
    enbw_hz: float
    fs: float
    f_det: float
    nu: float
    xi0: float
    n_samples: int
    harmonics: tuple
    gate: tuple
    search_hz: float
    max_freq_error_hz: float
    min_snr_db: float
    im_min_snr_db: float
    swap_sidebands: bool
    db_reference: str = field(
        default="dB re a sinusoid of unit peak amplitude in trace units (a cos -> 20 log10 a)")

    def sideband(self, name: str) -> SidebandTones:
        """``"red"`` or ``"blue"``."""
        return {"red": self.red, "blue": self.blue}[name]

    def to_dict(self) -> dict:
        """The JSON contract: ``red``/``blue`` (``P_dB``, ``valid``, ``R10_dB``,
        ``R23_dB``, ...), top-level ``R10_dB``/``R23_dB`` (means) and extras."""
        return {
            "red": self.red.to_dict(), "blue": self.blue.to_dict(),
            "R10_dB": self.R10_dB, "R23_dB": self.R23_dB,
            "R10_limit": self.R10_limit, "R23_limit": self.R23_limit,
            "noise_floor_dB": self.noise_floor_dB,
            "noise_band_hz": list(self.noise_band_hz), "n_noise_bins": self.n_noise_bins,
            "resolution_hz": self.resolution_hz, "enbw_hz": self.enbw_hz,
            "fs": self.fs, "f_det": self.f_det, "nu": self.nu, "xi0": self.xi0,
            "n_samples": self.n_samples, "harmonics": list(self.harmonics),
            "gate": list(self.gate), "search_hz": self.search_hz,
            "max_freq_error_hz": self.max_freq_error_hz, "min_snr_db": self.min_snr_db,
            "im_min_snr_db": self.im_min_snr_db, "swap_sidebands": self.swap_sidebands,
            "db_reference": self.db_reference,
        }

    def report(self) -> str:
        """Readable report: settings, noise floor, per-tone table, ratios."""
        def num(v, fmt):
            return "—" if v is None or not np.isfinite(v) else format(v, fmt)

        def ratio(v, lim):
            if v is None:
                return "—"
            return {None: "", "lower": ">", "upper": "<"}[lim] + f"{v:.2f}"

        lines = [
            "[[Heterodyne tone powers]] (Supplement S4: flat-top periodogram)",
            f"    trace            = {self.n_samples} samples at fs = "
            f"{_hz(self.fs).replace('Hz', 'S/s')} ({self.n_samples / self.fs * 1e3:.4g} ms), "
            f"bin = {self.resolution_hz:.4g} Hz",
            f"    beat             = f_det {_hz(self.f_det)}, nu {_hz(self.nu)}, "
            f"xi0 {_hz(self.xi0)}"
            + ("  (sidebands swapped)" if self.swap_sidebands else ""),
            "    dB reference     = 0 dB: sinusoid of unit peak amplitude (trace units)",
            f"    noise floor      = {num(self.noise_floor_dB, '.2f')} dB (median over "
            f"{_hz(self.noise_band_hz[0])} .. {_hz(self.noise_band_hz[1])}, "
            f"{self.n_noise_bins} bins, tones excluded)",
            f"    gate tones       = n in {list(self.gate)}: peak within +/-{self.search_hz:g} Hz, "
            f"valid if |error| < {self.max_freq_error_hz:g} Hz and SNR > {self.min_snr_db:g} dB",
            f"    IM tones         = read at the expected bin; SNR < {self.im_min_snr_db:g} dB: "
            "upper limit",
        ]
        for sb in (self.red, self.blue):
            sgn = "+" if sb.sign > 0 else "-"
            lines.append(f"[[{sb.name} sideband]] f_det {sgn} (nu + n xi0)")
            lines.append(f"    {'n':>3s} {'role':>4s} {'expected [Hz]':>15s} {'found [Hz]':>15s} "
                         f"{'error [Hz]':>10s} {'P [dB]':>9s} {'SNR [dB]':>8s}  valid")
            for n in self.harmonics:
                err = sb.freq_error_hz[n]
                lines.append(
                    f"    {n:3d} {sb.role[n]:>4s} {sb.expected_hz[n]:15.1f} {sb.found_hz[n]:15.1f} "
                    f"{num(err, '10.1f'):>10s} {num(sb.P_dB[n], '9.3f'):>9s} "
                    f"{num(sb.snr_db[n], '8.1f'):>8s}  "
                    + ("yes" if sb.valid[n] else f"NO ({sb.reason[n]})"))
        lines.append("[[Ratios]] dB ('>' lower limit, '<' upper limit, '—' not available)")
        lines.append(f"    {'':8s} {'red':>9s} {'blue':>9s} {'mean':>9s}")
        for key in ("R10", "R23"):
            vals = [(getattr(s, f"{key}_dB"), getattr(s, f"{key}_limit"))
                    for s in (self.red, self.blue)]
            vals.append((getattr(self, f"{key}_dB"), getattr(self, f"{key}_limit")))
            lines.append(f"    {key + ' [dB]':8s} " + " ".join(f"{ratio(*v):>9s}" for v in vals))
        return "\n".join(lines)


# ----------------------------------------------------------------------------- analysis


def _status(valid: bool, role: str) -> str:
    if valid:
        return "ok"
    return "upper" if role == "IM" else "bad"


def _ratio(P: dict, valid: dict, role: dict, a: int, b: int):
    """``P_a - P_b`` (dB) and its limit kind, or (None, None)."""
    if a not in P or b not in P:
        return None, None
    sa, sb = _status(valid[a], role[a]), _status(valid[b], role[b])
    if "bad" in (sa, sb) or (sa == "upper" and sb == "upper"):
        return None, None
    value = P[a] - P[b]
    if not np.isfinite(value):
        return None, None
    limit = "lower" if sb == "upper" else ("upper" if sa == "upper" else None)
    return float(value), limit


def _mean_ratio(pairs):
    if any(v is None for v, _ in pairs):
        return None, None
    limits = {lim for _, lim in pairs if lim is not None}
    if len(limits) > 1:
        return None, None
    return float(np.mean([v for v, _ in pairs])), (limits.pop() if limits else None)


def trace_tone_powers(trace, fs: float, f_det: float, nu: float, xi0: float,
                      harmonics: Iterable[int] = (0, 1, 2, 3), gate: Iterable[int] = (1, 2), *,
                      search_hz: float = 5e3, max_freq_error_hz: float = 1e3,
                      min_snr_db: float = 20.0, im_min_snr_db: float = 10.0,
                      swap_sidebands: bool = False) -> TraceSpectrum:
    """Powers of the gate and intermodulation tones in a heterodyne trace.

    Implements Supplement S4; the rules (noise floor, validation, limits)
    are given in the module docstring.

    Parameters
    ----------
    trace : array_like, shape (N,)
        Photodiode samples (any units; float64 is used throughout).
    fs : float
        Sample rate, Hz.
    f_det : float
        Offset of the reference beam (beat-note centre), Hz.
    nu : float
        Motional sideband frequency, Hz.
    xi0 : float
        Harmonic spacing of the waveform, Hz.
    harmonics : iterable of int
        Harmonics ``n`` to measure (any integers, e.g. ``-1`` and ``4`` for IM5).
    gate : iterable of int
        The gate tones among ``harmonics`` (peak search and validation); the
        others are read as IM tones.
    search_hz : float
        Half-width of the gate-tone peak search, Hz (5 kHz).
    max_freq_error_hz : float
        A gate tone is valid only if found closer than this to its expected
        frequency, Hz (1 kHz).
    min_snr_db : float
        ... and if more than this above the noise floor, dB (20).
    im_min_snr_db : float
        IM tones less than this above the floor are noise-limited (upper
        limits), dB (10).
    swap_sidebands : bool
        Blue group at ``f_det - (nu + n xi0)`` and red at ``f_det + ...``.

    Returns
    -------
    TraceSpectrum

    Raises
    ------
    InputError
        Bad parameters, non-finite samples, a trace too short to resolve
        ``xi0``, a sample rate too low for the detection band, red tones at
        or below 0 Hz, colliding tones.
    """
    fs = _fnum(fs, "fs")
    f_det = _fnum(f_det, "f_det")
    nu = _fnum(nu, "nu")
    xi0 = _fnum(xi0, "xi0")
    search_hz = _fnum(search_hz, "search_hz")
    max_freq_error_hz = _fnum(max_freq_error_hz, "max_freq_error_hz")
    min_snr_db = _fnum(min_snr_db, "min_snr_db", positive=False)
    im_min_snr_db = _fnum(im_min_snr_db, "im_min_snr_db", positive=False)
    harmonics = _harmonics(harmonics, "harmonics")
    gate = _harmonics(gate, "gate")
    if not harmonics:
        raise InputError("harmonics is empty: request at least one tone")
    missing = [n for n in gate if n not in harmonics]
    if missing:
        raise InputError(f"gate harmonic(s) {missing} are not among the requested "
                         f"harmonics {list(harmonics)}")
    x = _as_trace(trace)
    N = x.size
    df = fs / N
    L = MAIN_LOBE_BINS

    # resolution: adjacent harmonics' main lobes (+/-5 bins) must not overlap
    if L * df >= xi0 / 2:
        n_need = 2 * L * fs / xi0
        raise InputError(
            f"trace too short to resolve xi0 = {_hz(xi0)}: {N} samples at fs = {fs:g} Hz give "
            f"bins of fs/N = {_hz(df)}, and the flat-top main lobe spans +/-{L} bins, which must "
            f"stay within xi0/2 (5*fs/N < xi0/2); need more than {n_need:.0f} samples "
            f"({n_need / fs * 1e3:.3g} ms)")

    blue_sign = -1 if swap_sidebands else 1
    signs = {"red": -blue_sign, "blue": blue_sign}
    expected = {sb: {n: f_det + signs[sb] * (nu + n * xi0) for n in harmonics}
                for sb in _SIDEBANDS}
    margin = max(search_hz, L * df) + L * df
    margin_txt = (f"margin {_hz(margin)} = search window {_hz(search_hz)} or main lobe, "
                  f"plus the {L}-bin flat-top main lobe")
    tones = sorted((f, sb, n) for sb in _SIDEBANDS for n, f in expected[sb].items())
    f_max, sb_max, n_max = tones[-1]
    if f_max + margin >= fs / 2:
        raise InputError(
            f"sample rate too low: fs/2 = {_hz(fs / 2)} must exceed the highest tone "
            f"({sb_max} n={n_max} at {_hz(f_max)}) + {margin_txt}")
    f_min, sb_min, n_min_ = tones[0]
    if f_min <= margin:
        raise InputError(
            f"{sb_min} tone n={n_min_} at {_hz(f_min)} is at or below 0 Hz + {margin_txt}; "
            f"f_det must exceed nu + n*xi0 by more than the margin")
    for (f1, sb1, n1), (f2, sb2, n2) in zip(tones[:-1], tones[1:]):
        if f2 - f1 <= margin:
            raise InputError(
                f"requested tones collide: {sb1} n={n1} at {_hz(f1)} and {sb2} n={n2} at "
                f"{_hz(f2)} are {_hz(f2 - f1)} apart, not more than the {margin_txt}")

    # spectrum on the detection band only
    half = max(abs(f - f_det) for f, _, _ in tones) + NOISE_BAND_MARGIN * xi0
    last = N // 2
    k_lo = max(0, min(math.floor((f_det - half) / df), math.floor((f_min - margin) / df) - L))
    k_hi = min(last, max(math.ceil((f_det + half) / df), math.ceil((f_max + margin) / df) + L))
    X = scipy.fft.rfft(x)
    P = _band_psd(X, N, k_lo, k_hi)
    del X
    with np.errstate(divide="ignore"):
        P_dB_band = 10 * np.log10(2 * P)

    # noise floor: median over the band, requested tones' neighbourhoods excluded
    k = np.arange(k_lo, k_hi + 1)
    f_bins = k * df
    nb_lo, nb_hi = max(f_det - half, L * df), min(f_det + half, (last - L) * df)
    mask = (f_bins >= nb_lo) & (f_bins <= nb_hi)
    excl = search_hz + L * df
    for f, _, _ in tones:
        mask &= np.abs(f_bins - f) > excl
    if mask.sum() < 10:
        raise InputError("too few bins to estimate the noise floor (detection band "
                         f"{_hz(nb_lo)} .. {_hz(nb_hi)}); check f_det, nu and xi0")
    med = float(np.median(P[mask]))
    if med <= 0:
        raise InputError("the trace has no power in the detection band (all-zero or "
                         "constant trace?)")
    floor_dB = 10 * math.log10(2 * med)

    sidebands = {}
    for sb in _SIDEBANDS:
        role, found, err, Pd, snr, valid, reason = {}, {}, {}, {}, {}, {}, {}
        for n in harmonics:
            f0 = expected[sb][n]
            if n in gate:
                role[n] = "gate"
                w_lo = math.ceil((f0 - search_hz) / df - 1e-9)
                w_hi = math.floor((f0 + search_hz) / df + 1e-9)
                if w_hi < w_lo:                      # window narrower than a bin
                    w_lo = w_hi = int(round(f0 / df))
                win = P[w_lo - k_lo:w_hi - k_lo + 1]
                pk = w_lo + int(np.argmax(win))
                c_lo, c_hi = max(pk - L, k_lo), min(pk + L, k_hi)
                pw = P[c_lo - k_lo:c_hi - k_lo + 1]
                centroid = (float(np.dot(np.arange(c_lo, c_hi + 1), pw) / pw.sum())
                            if pw.sum() > 0 else float(pk))
                f_found = centroid * df
                kr = min(max(int(round(centroid)), w_lo), w_hi)
                found[n], err[n] = f_found, f_found - f0
                Pd[n] = float(P_dB_band[kr - k_lo])
                snr[n] = Pd[n] - floor_dB
                why = []
                if not abs(err[n]) < max_freq_error_hz:
                    why.append(f"frequency error {err[n]:+.0f} Hz "
                               f"(limit +/-{max_freq_error_hz:g} Hz)")
                if not snr[n] > min_snr_db:
                    why.append(f"SNR {snr[n]:.1f} dB not above {min_snr_db:g} dB")
                valid[n] = not why
                reason[n] = "; ".join(why) if why else "ok"
            else:
                role[n] = "IM"
                kr = int(round(f0 / df))
                found[n], err[n] = kr * df, None
                Pd[n] = float(P_dB_band[kr - k_lo])
                snr[n] = Pd[n] - floor_dB
                valid[n] = bool(snr[n] >= im_min_snr_db)
                reason[n] = "ok" if valid[n] else AT_NOISE_FLOOR
        r10, l10 = _ratio(Pd, valid, role, 1, 0)
        r23, l23 = _ratio(Pd, valid, role, 2, 3)
        sidebands[sb] = SidebandTones(
            name=sb, sign=signs[sb], role=ToneMap(role), expected_hz=ToneMap(expected[sb]),
            found_hz=ToneMap(found), freq_error_hz=ToneMap(err), P_dB=ToneMap(Pd),
            snr_db=ToneMap(snr), valid=ToneMap(valid), reason=ToneMap(reason),
            R10_dB=r10, R23_dB=r23, R10_limit=l10, R23_limit=l23)

    red, blue = sidebands["red"], sidebands["blue"]
    R10, L10 = _mean_ratio([(red.R10_dB, red.R10_limit), (blue.R10_dB, blue.R10_limit)])
    R23, L23 = _mean_ratio([(red.R23_dB, red.R23_limit), (blue.R23_dB, blue.R23_limit)])
    a = np.asarray(FLATTOP_COEFFICIENTS)
    enbw_bins = float(a[0] ** 2 + np.sum(a[1:] ** 2) / 2) / a[0] ** 2
    return TraceSpectrum(
        red=red, blue=blue, R10_dB=R10, R23_dB=R23, R10_limit=L10, R23_limit=L23,
        noise_floor_dB=floor_dB, noise_band_hz=(float(nb_lo), float(nb_hi)),
        n_noise_bins=int(mask.sum()), resolution_hz=df, enbw_hz=enbw_bins * df, fs=fs,
        f_det=f_det, nu=nu, xi0=xi0, n_samples=N, harmonics=harmonics, gate=gate,
        search_hz=search_hz, max_freq_error_hz=max_freq_error_hz, min_snr_db=min_snr_db,
        im_min_snr_db=im_min_snr_db, swap_sidebands=bool(swap_sidebands))


# ----------------------------------------------------------------------------- simulation


def simulate_beat_trace(fs: float, n_samples: int, f_det: float, tones,
                        noise_rms: float = 0.0, rng=None) -> np.ndarray:
    """Synthetic photodiode beat trace: tones around ``f_det`` plus white noise.

    Parameters
    ----------
    fs : float
        Sample rate, Hz.
    n_samples : int
        Number of samples ``N`` (``t_j = j / fs``, ``j = 0..N-1``).
    f_det : float
        Beat-note centre, Hz.
    tones : iterable of (float, float, float)
        ``(frequency_hz, amplitude, phase_rad)`` with ``frequency_hz`` the
        signed offset from ``f_det``: the trace contains
        ``amplitude * cos(2 pi (f_det + frequency_hz) t + phase_rad)``.  E.g.
        the blue tone ``n`` is at ``+(nu + n xi0)``, the red at ``-(nu + n xi0)``.
    noise_rms : float
        Standard deviation of additive white Gaussian noise (trace units).
    rng : None, int or numpy.random.Generator
        Seed or generator for the noise.

    Returns
    -------
    ndarray, shape (N,), float64
    """
    fs = _fnum(fs, "fs")
    f_det = _fnum(f_det, "f_det")
    noise_rms = _fnum(noise_rms, "noise_rms", positive=False)
    if noise_rms < 0:
        raise InputError(f"noise_rms must be >= 0, got {noise_rms:g}")
    if int(n_samples) != n_samples or n_samples < 1:
        raise InputError(f"n_samples must be a positive integer, got {n_samples!r}")
    n = int(n_samples)
    j = np.arange(n, dtype=np.float64)
    out = np.zeros(n)
    for i, tone in enumerate(tones):
        try:
            f, amp, ph = (float(v) for v in tone)
        except (TypeError, ValueError):
            raise InputError(f"tone {i}: expected (frequency_hz, amplitude, phase_rad), "
                             f"got {tone!r}") from None
        if not all(map(math.isfinite, (f, amp, ph))):
            raise InputError(f"tone {i}: values must be finite, got {tone!r}")
        fa = f_det + f
        if not 0 < fa < fs / 2:
            raise InputError(f"tone {i}: f_det + frequency = {_hz(fa)} is outside "
                             f"(0, fs/2 = {_hz(fs / 2)})")
        cycles = np.mod(j * (fa / fs), 1.0)        # keep the cosine argument small
        out += amp * np.cos(2 * np.pi * cycles + ph)
    if noise_rms > 0:
        out += noise_rms * np.random.default_rng(rng).standard_normal(n)
    return out


# ----------------------------------------------------------------------------- loading


def _load_csv(path: Path) -> np.ndarray:
    name = str(path)
    first = None
    with open(path, encoding="utf-8", errors="replace") as fh:
        for line in fh:
            s = line.strip()
            if s and not s.startswith("#"):
                first = s
                break
    if first is None:
        raise InputError("file is empty (no samples)", file=name)
    ncols = len(first.split(","))
    if ncols != 1:
        raise InputError(f"{ncols} columns in the first line; expected one column of samples",
                         file=name)
    try:
        float(first)
        header = None
    except ValueError:
        header = 0
    kw = dict(header=header, comment="#", skipinitialspace=True, skip_blank_lines=True)
    try:
        df = pd.read_csv(path, dtype=np.float64, **kw)
        col = None if header is None else str(df.columns[0]).strip()
    except (ValueError, pd.errors.ParserError) as exc:
        if isinstance(exc, pd.errors.ParserError):
            msg = str(exc).strip().splitlines()[-1]
            raise InputError(f"more than one column? ({msg})", file=name) from None
        raw = pd.read_csv(path, dtype=str, keep_default_na=False, **kw)
        col = None if header is None else str(raw.columns[0]).strip()
        text = raw.iloc[:, 0].astype(str).str.strip()
        vals = pd.to_numeric(text, errors="coerce")
        bad = np.flatnonzero(vals.isna().to_numpy())
        if bad.size == 0:  # pragma: no cover - pandas refused a column it can parse
            raise InputError(f"not a readable CSV file ({exc})", file=name) from None
        i = int(bad[0])
        t = text.iloc[i]
        what = "value is empty" if t == "" else f"'{t}' is not a number"
        raise InputError(what, file=name, column=col, row=i + 1) from None
    except pd.errors.EmptyDataError:
        raise InputError("file is empty (no samples)", file=name) from None
    if df.shape[1] != 1:
        raise InputError(f"{df.shape[1]} columns; expected one column of samples", file=name)
    if df.shape[0] == 0:
        raise InputError("file has a header but no samples", file=name)
    x = df.iloc[:, 0].to_numpy(dtype=np.float64)
    bad = ~np.isfinite(x)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"value is {x[i]} (must be finite)", file=name, column=col, row=i + 1)
    return x


def load_trace(path: str | os.PathLike) -> np.ndarray:
    """Read a photodiode trace.

    Parameters
    ----------
    path : path-like
        * ``.npy``: a 1-D (or ``(N, 1)``) integer or float array;
        * ``.npz``: key ``trace`` (as above) and optional ``scale`` (finite,
          nonzero scalar, e.g. volts per ADC count) that multiplies it;
        * ``.csv`` / ``.txt``: one column of numbers, header line optional,
          ``#`` lines are comments.

    Returns
    -------
    ndarray, shape (N,), float64

    Raises
    ------
    InputError
        Missing file, unsupported type, wrong shape or dtype, more than one
        column, empty, non-numeric or non-finite values (the message names
        the file and, for a value, the 1-based row / sample number).
    """
    p = Path(path)
    name = str(path)
    if not p.exists():
        raise InputError("file not found", file=name)
    ext = p.suffix.lower()
    if ext in (".csv", ".txt"):
        return _load_csv(p)
    if ext not in (".npy", ".npz"):
        raise InputError(f"unsupported file type '{p.suffix}'; expected .npy, .npz or a "
                         "one-column .csv", file=name)
    try:
        obj = np.load(p, allow_pickle=False)
    except ValueError as exc:
        raise InputError(f"not a numeric NumPy file ({str(exc).splitlines()[0]})",
                         file=name) from None
    except (OSError, EOFError) as exc:
        raise InputError(f"not a readable NumPy file ({exc})", file=name) from None
    scale = 1.0
    if ext == ".npz" or not isinstance(obj, np.ndarray):
        with obj as z:
            keys = list(z.keys())
            if "trace" not in keys:
                raise InputError(f"no array 'trace' in the .npz (keys: {keys})", file=name)
            try:
                arr = z["trace"]
                sc = z["scale"] if "scale" in keys else None
            except ValueError as exc:
                raise InputError(f"not a numeric array ({exc})", file=name) from None
        if sc is not None:
            sc = np.asarray(sc)
            if sc.size != 1 or sc.dtype.kind not in "iuf":
                raise InputError(f"'scale' must be one real number, got shape {sc.shape} "
                                 f"dtype {sc.dtype}", file=name)
            scale = float(sc.reshape(()))
            if not math.isfinite(scale) or scale == 0:
                raise InputError(f"'scale' must be finite and nonzero, got {scale}", file=name)
    else:
        arr = obj
    x = _as_trace(arr, file=name)
    return x * scale if scale != 1.0 else x


# ----------------------------------------------------------------------------- CLI


def _parse_int_list(spec: str, option: str) -> tuple[int, ...]:
    out = []
    for tok in str(spec).split(","):
        tok = tok.strip()
        if not tok:
            continue
        try:
            out.append(int(tok))
        except ValueError:
            raise InputError(f"{option}: '{tok}' is not an integer (use e.g. 0,1,2,3)") from None
    return tuple(out)


def trace_estimate(res: "TraceSpectrum", nbar: float = 0.1, formula: str = "exact") -> dict:
    """Spectrum-based fidelity estimate (S5) from a trace's tone powers.

    Per sideband group: ``F_est`` from the measured ``P_n`` of all requested
    harmonics (needs the gate tones valid; otherwise ``None``).  An IM tone at
    the noise floor enters with its reading, an upper limit of its power, so
    ``F_est`` is then a lower limit (``limit: "lower"``).  ``mean`` averages the
    two sidebands (S5.4).
    """
    from dpdfit.models.fidelity import estimate
    out = {}
    for name in ("red", "blue"):
        t = getattr(res, name)
        if not all(t.valid[n] for n in res.gate):
            out[name] = {"F_est": None, "eps_est": None, "limit": None,
                         "reason": "a gate tone failed validation"}
            continue
        h = list(res.harmonics)
        est = estimate([t.P_dB[n] for n in h], h, gate=tuple(res.gate), nbar=nbar,
                       formula=formula)
        lim = "lower" if any(not t.valid[n] for n in h if n not in res.gate) else None
        out[name] = {"F_est": float(est.F_est), "eps_est": float(est.eps_est), "limit": lim,
                     "reason": "ok"}
    r, b = out["red"], out["blue"]
    if r["F_est"] is None or b["F_est"] is None:
        out["F_est"], out["eps_est"], out["limit"] = None, None, None
    else:
        out["F_est"] = 0.5 * (r["F_est"] + b["F_est"])
        out["eps_est"] = 1.0 - out["F_est"]
        out["limit"] = "lower" if (r["limit"] or b["limit"]) else None
    out.update(formula=formula, nbar=float(nbar))
    return out


def delta_powers(res_dpd: "TraceSpectrum", res_ref: "TraceSpectrum") -> dict:
    """``dP_n = P_n(this) - P_n(reference)`` in dB per sideband and their mean.

    For DPD vs no-DPD traces at matched A (S9).  A difference is ``None``
    unless the tone is valid in both traces.
    """
    out = {}
    for name in ("red", "blue"):
        a, b = getattr(res_dpd, name), getattr(res_ref, name)
        out[name] = {str(n): (a.P_dB[n] - b.P_dB[n] if a.valid[n] and b.valid[n] else None)
                     for n in res_dpd.harmonics if n in res_ref.harmonics}
    out["mean"] = {k: (None if out["red"][k] is None or out["blue"][k] is None
                       else 0.5 * (out["red"][k] + out["blue"][k])) for k in out["red"]}
    return out


def cmd_spectrum(args) -> int:
    """``dpdfit spectrum``: tone powers of a heterodyne trace (report or JSON)."""
    if args.output:
        refuse_overwriting_inputs([args.output], [args.trace, args.compare])
    harmonics = _parse_int_list(args.harmonics, "--harmonics")
    gate = _parse_int_list(args.gate, "--gate")

    def analyse(path):
        try:
            return trace_tone_powers(
                load_trace(path), args.fs, args.fdet, args.nu, args.xi0, harmonics=harmonics,
                gate=gate, search_hz=args.search_hz, max_freq_error_hz=args.max_freq_error_hz,
                min_snr_db=args.min_snr_db, im_min_snr_db=args.im_min_snr_db,
                swap_sidebands=args.swap_sidebands)
        except InputError as exc:
            if exc.file is None:
                raise InputError(str(exc), file=str(path)) from None
            raise

    res = analyse(args.trace)
    d = res.to_dict()
    d["source"] = str(args.trace)
    if args.estimate:
        d["estimate"] = trace_estimate(res, args.nbar, args.formula)
    if args.compare:
        ref = analyse(args.compare)
        d["dP_dB"] = delta_powers(res, ref)
        d["compare_source"] = str(args.compare)
    if args.output:
        atomic_write_json(args.output, d)
    if args.json:
        print(json.dumps(to_jsonable(d), indent=2))
    else:
        print(res.report())
        if args.estimate:
            e = d["estimate"]
            def _f(v):
                return "-" if v is None else f"{v:.6f}"
            print(f"[[Estimate]] (S5, formula {e['formula']}, nbar {e['nbar']:g})"
                  + ("  lower limits: an IM tone is at the noise floor" if e["limit"] else ""))
            print(f"    F_est red {_f(e['red']['F_est'])}   blue {_f(e['blue']['F_est'])}"
                  f"   mean {_f(e['F_est'])}")
        if args.compare:
            dp = d["dP_dB"]["mean"]
            print(f"[[dP vs {args.compare}]] mean over sidebands: "
                  + ", ".join(f"dP{k} = {'-' if v is None else f'{v:+.3f}'} dB"
                              for k, v in dp.items()))
        if args.output:
            print(f"wrote {args.output}", file=sys.stderr)
    return 0


def add_spectrum_command(subparsers) -> argparse.ArgumentParser:
    """Register the ``spectrum`` sub-command on an argparse sub-parsers object.

    ``dpdfit spectrum TRACE --fs HZ --fdet HZ --nu HZ --xi0 HZ [--json]
    [--harmonics 0,1,2,3] [--gate 1,2] [--swap-sidebands] [-o OUT.json]``.
    The registered ``func`` returns an exit code and raises
    :class:`~dpdfit.errors.DpdfitError` on bad input.
    """
    s = subparsers.add_parser(
        "spectrum", help="tone powers and IM ratios from a heterodyne photodiode trace",
        description="Gate and intermodulation tone powers (dB re a unit-amplitude sinusoid) "
                    "from a flat-top periodogram of a heterodyne beat trace (Supplement S4).")
    s.add_argument("trace", help=".npy (1-D), .npz (keys trace[, scale]) or one-column .csv")
    s.add_argument("--fs", type=float, required=True, help="sample rate, Hz")
    s.add_argument("--fdet", type=float, required=True, help="reference offset f_det, Hz")
    s.add_argument("--nu", type=float, required=True, help="motional sideband nu, Hz")
    s.add_argument("--xi0", type=float, required=True, help="harmonic spacing xi0, Hz")
    s.add_argument("--harmonics", default="0,1,2,3",
                   help="harmonics n to measure (0,1,2,3); negative values need '=', "
                        "e.g. --harmonics=-1,0,1,2,3,4")
    s.add_argument("--gate", default="1,2", help="gate-tone harmonics (1,2)")
    s.add_argument("--search-hz", type=float, default=5e3,
                   help="gate-tone peak search half-width, Hz (5000)")
    s.add_argument("--max-freq-error-hz", type=float, default=1e3,
                   help="gate-tone frequency tolerance, Hz (1000)")
    s.add_argument("--min-snr-db", type=float, default=20.0,
                   help="gate-tone minimum SNR over the median noise floor, dB (20)")
    s.add_argument("--im-min-snr-db", type=float, default=10.0,
                   help="IM tones below this SNR are upper limits, dB (10)")
    s.add_argument("--swap-sidebands", action="store_true",
                   help="blue group at f_det - (nu + n xi0), red at f_det + ...")
    s.add_argument("--estimate", action="store_true",
                   help="add the spectrum-based fidelity estimate F_est (S5)")
    s.add_argument("--nbar", type=float, default=0.1, help="thermal phonon number (0.1)")
    s.add_argument("--formula", choices=["exact", "paper"], default="exact",
                   help="Bell-fidelity expression for --estimate (exact)")
    s.add_argument("--compare", metavar="REF_TRACE",
                   help="reference trace (e.g. no DPD at the same A): adds dP_n = P_n - P_n(ref)")
    s.add_argument("--json", action="store_true", help="print the JSON instead of a report")
    s.add_argument("-o", "--output", help="also write the JSON to this file")
    s.set_defaults(func=cmd_spectrum)
    return s
