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
   bins).  Only the bins of the detection band are formed, by
   :func:`~dpdfit.fits.tones.periodogram.flattop_band_power` (same numbers
   as scipy's, ~7x faster; see :mod:`dpdfit.fits.tones.periodogram`).
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

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import scipy.fft

from dpdfit.errors import InputError
from dpdfit.fits.tones.params import finite_float, format_hz, harmonic_numbers
from dpdfit.fits.tones.periodogram import FLATTOP_ENBW_BINS, MAIN_LOBE_BINS, flattop_band_power
from dpdfit.fits.tones.results import SidebandTones, ToneMap, TraceSpectrum
from dpdfit.recordings.traces import as_trace

__all__ = ["trace_tone_powers", "check_trace_layout", "NOISE_BAND_MARGIN", "AT_NOISE_FLOOR"]

#: The noise-floor band extends this many harmonic spacings xi0 beyond the
#: outermost requested tone.
NOISE_BAND_MARGIN = 2
#: ``reason`` of an IM tone whose power is within ``im_min_snr_db`` of the floor.
AT_NOISE_FLOOR = "at noise floor: upper limit"

_SIDEBANDS = ("red", "blue")


@dataclass(frozen=True)
class _Settings:
    """The checked parameters of :func:`trace_tone_powers`."""

    fs: float
    f_det: float
    nu: float
    xi0: float
    harmonics: tuple
    gate: tuple
    search_hz: float
    max_freq_error_hz: float
    min_snr_db: float
    im_min_snr_db: float
    swap_sidebands: bool


@dataclass(frozen=True)
class _Band:
    """Periodogram ``P`` (and ``P_dB``) on the bins ``k_lo..k_hi`` of the detection band."""

    k_lo: int
    k_hi: int
    df: float
    P: np.ndarray
    P_dB: np.ndarray


def _settings(fs, f_det, nu, xi0, harmonics, gate, search_hz, max_freq_error_hz, min_snr_db,
              im_min_snr_db, swap_sidebands) -> _Settings:
    """Check and convert the parameters (InputError naming the first bad one)."""
    fs = finite_float(fs, "fs")
    f_det = finite_float(f_det, "f_det")
    nu = finite_float(nu, "nu")
    xi0 = finite_float(xi0, "xi0")
    search_hz = finite_float(search_hz, "search_hz")
    max_freq_error_hz = finite_float(max_freq_error_hz, "max_freq_error_hz")
    min_snr_db = finite_float(min_snr_db, "min_snr_db", positive=False)
    im_min_snr_db = finite_float(im_min_snr_db, "im_min_snr_db", positive=False)
    harmonics = harmonic_numbers(harmonics, "harmonics")
    gate = harmonic_numbers(gate, "gate")
    if not harmonics:
        raise InputError("harmonics is empty: request at least one tone")
    missing = [n for n in gate if n not in harmonics]
    if missing:
        raise InputError(f"gate harmonic(s) {missing} are not among the requested "
                         f"harmonics {list(harmonics)}")
    return _Settings(fs, f_det, nu, xi0, harmonics, gate, search_hz, max_freq_error_hz,
                     min_snr_db, im_min_snr_db, bool(swap_sidebands))


def _check_resolution(N: int, s: _Settings) -> None:
    """Adjacent harmonics' main lobes (+/-5 bins) must not overlap."""
    df = s.fs / N
    L = MAIN_LOBE_BINS
    if L * df >= s.xi0 / 2:
        n_need = 2 * L * s.fs / s.xi0
        raise InputError(
            f"trace too short to resolve xi0 = {format_hz(s.xi0)}: {N} samples at fs = "
            f"{s.fs:g} Hz give bins of fs/N = {format_hz(df)}, and the flat-top main lobe "
            f"spans +/-{L} bins, which must stay within xi0/2 (5*fs/N < xi0/2); need more "
            f"than {n_need:.0f} samples ({n_need / s.fs * 1e3:.3g} ms)")


def _check_tone_layout(expected: dict, df: float, s: _Settings) -> tuple[list, float]:
    """All requested tones sorted as ``(f, sideband, n)``, and the margin between them.

    InputError if a tone is too close to Nyquist or to 0 Hz, or two tones collide.
    """
    L = MAIN_LOBE_BINS
    margin = max(s.search_hz, L * df) + L * df
    margin_txt = (f"margin {format_hz(margin)} = search window {format_hz(s.search_hz)} or "
                  f"main lobe, plus the {L}-bin flat-top main lobe")
    tones = sorted((f, sb, n) for sb in _SIDEBANDS for n, f in expected[sb].items())
    f_max, sb_max, n_max = tones[-1]
    if f_max + margin >= s.fs / 2:
        raise InputError(
            f"sample rate too low: fs/2 = {format_hz(s.fs / 2)} must exceed the highest tone "
            f"({sb_max} n={n_max} at {format_hz(f_max)}) + {margin_txt}")
    f_min, sb_min, n_min_ = tones[0]
    if f_min <= margin:
        raise InputError(
            f"{sb_min} tone n={n_min_} at {format_hz(f_min)} is at or below 0 Hz + "
            f"{margin_txt}; f_det must exceed nu + n*xi0 by more than the margin")
    for (f1, sb1, n1), (f2, sb2, n2) in zip(tones[:-1], tones[1:]):
        if f2 - f1 <= margin:
            raise InputError(
                f"requested tones collide: {sb1} n={n1} at {format_hz(f1)} and {sb2} n={n2} "
                f"at {format_hz(f2)} are {format_hz(f2 - f1)} apart, not more than the "
                f"{margin_txt}")
    return tones, margin


def _layout(N: int, s: _Settings) -> tuple:
    """``(signs, expected, tones, margin)`` of a trace of ``N`` samples: the sign of each
    sideband, the expected frequency of each requested tone, the tones sorted and their
    margin; InputError when the trace cannot resolve them (resolution, margins)."""
    _check_resolution(N, s)
    blue_sign = -1 if s.swap_sidebands else 1
    signs = {"red": -blue_sign, "blue": blue_sign}
    expected = {sb: {n: s.f_det + signs[sb] * (s.nu + n * s.xi0) for n in s.harmonics}
                for sb in _SIDEBANDS}
    tones, margin = _check_tone_layout(expected, s.fs / N, s)
    return signs, expected, tones, margin


def check_trace_layout(n_samples: int, fs: float, f_det: float, nu: float, xi0: float,
                       harmonics: Iterable[int] = (0, 1, 2, 3), gate: Iterable[int] = (1, 2),
                       *, search_hz: float = 5e3, swap_sidebands: bool = False) -> None:
    """The checks of :func:`trace_tone_powers` that need no samples: its InputError when a
    trace of ``n_samples`` at these settings could not be read (bad parameters, too short
    to resolve ``xi0``, a sample rate too low, red tones at or below 0 Hz, colliding
    tones), before such a trace is made."""
    s = _settings(fs, f_det, nu, xi0, harmonics, gate, search_hz, 1e3, 20.0, 10.0,
                  swap_sidebands)
    _layout(int(n_samples), s)


def _band_spectrum(x: np.ndarray, df: float, f_det: float, half: float, tones: list,
                   margin: float) -> _Band:
    """Flat-top periodogram on the detection band (and the tones' search windows)."""
    N = x.size
    L = MAIN_LOBE_BINS
    f_min, f_max = tones[0][0], tones[-1][0]
    last = N // 2
    k_lo = max(0, min(math.floor((f_det - half) / df), math.floor((f_min - margin) / df) - L))
    k_hi = min(last, max(math.ceil((f_det + half) / df), math.ceil((f_max + margin) / df) + L))
    P = flattop_band_power(scipy.fft.rfft(x), N, k_lo, k_hi)
    with np.errstate(divide="ignore"):
        P_dB = 10 * np.log10(2 * P)
    return _Band(k_lo, k_hi, df, P, P_dB)


def _noise_floor(band: _Band, N: int, f_det: float, half: float, tones: list,
                 search_hz: float) -> tuple[float, tuple, int]:
    """Median noise floor over the band, tones' neighbourhoods excluded (step 3).

    Returns ``(floor_dB, (lo, hi) Hz, n_bins)``.
    """
    df, L = band.df, MAIN_LOBE_BINS
    f_bins = np.arange(band.k_lo, band.k_hi + 1) * df
    nb_lo, nb_hi = max(f_det - half, L * df), min(f_det + half, (N // 2 - L) * df)
    mask = (f_bins >= nb_lo) & (f_bins <= nb_hi)
    excl = search_hz + L * df
    for f, _, _ in tones:
        mask &= np.abs(f_bins - f) > excl
    if mask.sum() < 10:
        raise InputError("too few bins to estimate the noise floor (detection band "
                         f"{format_hz(nb_lo)} .. {format_hz(nb_hi)}); check f_det, nu and xi0")
    med = float(np.median(band.P[mask]))
    if med <= 0:
        raise InputError("the trace has no power in the detection band (all-zero or "
                         "constant trace?)")
    return 10 * math.log10(2 * med), (float(nb_lo), float(nb_hi)), int(mask.sum())


def _gate_tone(band: _Band, f0: float, floor_dB: float, s: _Settings) -> dict:
    """Peak search within +/-search_hz, main-lobe centroid, validation (step 4)."""
    df, k_lo, k_hi, L = band.df, band.k_lo, band.k_hi, MAIN_LOBE_BINS
    w_lo = math.ceil((f0 - s.search_hz) / df - 1e-9)
    w_hi = math.floor((f0 + s.search_hz) / df + 1e-9)
    if w_hi < w_lo:                      # window narrower than a bin
        w_lo = w_hi = int(round(f0 / df))
    win = band.P[w_lo - k_lo:w_hi - k_lo + 1]
    pk = w_lo + int(np.argmax(win))
    c_lo, c_hi = max(pk - L, k_lo), min(pk + L, k_hi)
    pw = band.P[c_lo - k_lo:c_hi - k_lo + 1]
    centroid = (float(np.dot(np.arange(c_lo, c_hi + 1), pw) / pw.sum())
                if pw.sum() > 0 else float(pk))
    f_found = centroid * df
    kr = min(max(int(round(centroid)), w_lo), w_hi)
    err = f_found - f0
    P_dB = float(band.P_dB[kr - k_lo])
    snr = P_dB - floor_dB
    why = []
    if not abs(err) < s.max_freq_error_hz:
        why.append(f"frequency error {err:+.0f} Hz (limit +/-{s.max_freq_error_hz:g} Hz)")
    if not snr > s.min_snr_db:
        why.append(f"SNR {snr:.1f} dB not above {s.min_snr_db:g} dB")
    return dict(role="gate", found=f_found, err=err, P_dB=P_dB, snr=snr, valid=not why,
                reason="; ".join(why) if why else "ok")


def _im_tone(band: _Band, f0: float, floor_dB: float, s: _Settings) -> dict:
    """Read at the bin nearest to the expected frequency (step 5)."""
    kr = int(round(f0 / band.df))
    P_dB = float(band.P_dB[kr - band.k_lo])
    snr = P_dB - floor_dB
    valid = bool(snr >= s.im_min_snr_db)
    return dict(role="IM", found=kr * band.df, err=None, P_dB=P_dB, snr=snr, valid=valid,
                reason="ok" if valid else AT_NOISE_FLOOR)


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


def _sideband(name: str, sign: int, expected: dict, band: _Band, floor_dB: float,
              s: _Settings) -> SidebandTones:
    """Every requested tone of one sideband group, and its R10, R23 (step 6)."""
    tones = {n: (_gate_tone if n in s.gate else _im_tone)(band, expected[n], floor_dB, s)
             for n in s.harmonics}

    def column(key):
        return {n: t[key] for n, t in tones.items()}

    Pd, valid, role = column("P_dB"), column("valid"), column("role")
    r10, l10 = _ratio(Pd, valid, role, 1, 0)
    r23, l23 = _ratio(Pd, valid, role, 2, 3)
    return SidebandTones(
        name=name, sign=sign, role=ToneMap(role), expected_hz=ToneMap(expected),
        found_hz=ToneMap(column("found")), freq_error_hz=ToneMap(column("err")),
        P_dB=ToneMap(Pd), snr_db=ToneMap(column("snr")), valid=ToneMap(valid),
        reason=ToneMap(column("reason")), R10_dB=r10, R23_dB=r23, R10_limit=l10, R23_limit=l23)


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
    s = _settings(fs, f_det, nu, xi0, harmonics, gate, search_hz, max_freq_error_hz,
                  min_snr_db, im_min_snr_db, swap_sidebands)
    x = as_trace(trace)
    N = x.size
    df = s.fs / N
    signs, expected, tones, margin = _layout(N, s)
    half = max(abs(f - s.f_det) for f, _, _ in tones) + NOISE_BAND_MARGIN * s.xi0
    band = _band_spectrum(x, df, s.f_det, half, tones, margin)
    floor_dB, noise_band, n_noise = _noise_floor(band, N, s.f_det, half, tones, s.search_hz)
    red, blue = (_sideband(sb, signs[sb], expected[sb], band, floor_dB, s) for sb in _SIDEBANDS)
    R10, L10 = _mean_ratio([(red.R10_dB, red.R10_limit), (blue.R10_dB, blue.R10_limit)])
    R23, L23 = _mean_ratio([(red.R23_dB, red.R23_limit), (blue.R23_dB, blue.R23_limit)])
    return TraceSpectrum(
        red=red, blue=blue, R10_dB=R10, R23_dB=R23, R10_limit=L10, R23_limit=L23,
        noise_floor_dB=floor_dB, noise_band_hz=noise_band, n_noise_bins=n_noise,
        resolution_hz=df, enbw_hz=FLATTOP_ENBW_BINS * df, fs=s.fs, f_det=s.f_det, nu=s.nu,
        xi0=s.xi0, n_samples=N, harmonics=s.harmonics, gate=s.gate, search_hz=s.search_hz,
        max_freq_error_hz=s.max_freq_error_hz, min_snr_db=s.min_snr_db,
        im_min_snr_db=s.im_min_snr_db, swap_sidebands=s.swap_sidebands)
