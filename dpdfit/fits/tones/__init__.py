"""Tone powers of a recorded heterodyne photodiode trace (Supplement S4).

* :mod:`~dpdfit.fits.tones.periodogram` -- the flat-top periodogram (whole
  spectrum or one band);
* :mod:`~dpdfit.fits.tones.extract` -- :func:`trace_tone_powers`: noise floor,
  gate-tone peak search and validation, IM read-out, ratios R10 and R23 (the
  procedure is described in that module's docstring);
* :mod:`~dpdfit.fits.tones.results` -- :class:`TraceSpectrum`,
  :class:`SidebandTones`, :class:`ToneMap` (JSON contract and report);
* :mod:`~dpdfit.fits.tones.params` -- parameter checks shared with the
  beat-trace simulator.

Trace files are read by :func:`dpdfit.recordings.traces.load_trace`.
"""

from dpdfit.fits.tones.periodogram import (FLATTOP_COEFFICIENTS, MAIN_LOBE_BINS,
                                           flattop_periodogram)
from dpdfit.fits.tones.results import SidebandTones, ToneMap, TraceSpectrum
from dpdfit.fits.tones.extract import AT_NOISE_FLOOR, NOISE_BAND_MARGIN, trace_tone_powers

__all__ = ["trace_tone_powers", "TraceSpectrum", "SidebandTones", "ToneMap",
           "flattop_periodogram", "FLATTOP_COEFFICIENTS", "MAIN_LOBE_BINS",
           "NOISE_BAND_MARGIN", "AT_NOISE_FLOOR"]
