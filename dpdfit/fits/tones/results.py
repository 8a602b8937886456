"""Results of the tone extraction: per-sideband tone tables and the trace's spectrum summary.

:class:`TraceSpectrum` (returned by :func:`dpdfit.fits.tones.trace_tone_powers`)
holds the two :class:`SidebandTones` groups, the noise floor and the settings,
and writes the JSON contract (:meth:`TraceSpectrum.to_dict`) and the readable
report (:meth:`TraceSpectrum.report`).  Tone-wise values are :class:`ToneMap`
objects keyed by the harmonic number ``n``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from dpdfit.core.display import Displayable
from dpdfit.fits.tones.params import format_hz

__all__ = ["ToneMap", "SidebandTones", "TraceSpectrum"]


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


@dataclass(frozen=True, repr=False)
class SidebandTones(Displayable):
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

    def to_frame(self) -> pd.DataFrame:
        """One row per harmonic ``n``: role, frequencies, P_dB, snr_db, valid, reason."""
        cols = ("role", "expected_hz", "found_hz", "freq_error_hz", "P_dB", "snr_db", "valid",
                "reason")
        return pd.DataFrame([{"sideband": self.name, "n": n, **{c: getattr(self, c)[n]
                                                              for c in cols}}
                             for n in self.P_dB])


@dataclass(frozen=True, repr=False)
class TraceSpectrum(Displayable):
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

    def to_frame(self) -> pd.DataFrame:
        """The tone table of both sidebands (:meth:`SidebandTones.to_frame`), red first."""
        return pd.concat([self.red.to_frame(), self.blue.to_frame()], ignore_index=True)

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
            f"{format_hz(self.fs).replace('Hz', 'S/s')} "
            f"({self.n_samples / self.fs * 1e3:.4g} ms), bin = {self.resolution_hz:.4g} Hz",
            f"    beat             = f_det {format_hz(self.f_det)}, nu {format_hz(self.nu)}, "
            f"xi0 {format_hz(self.xi0)}"
            + ("  (sidebands swapped)" if self.swap_sidebands else ""),
            "    dB reference     = 0 dB: sinusoid of unit peak amplitude (trace units)",
            f"    noise floor      = {num(self.noise_floor_dB, '.2f')} dB (median over "
            f"{format_hz(self.noise_band_hz[0])} .. {format_hz(self.noise_band_hz[1])}, "
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

