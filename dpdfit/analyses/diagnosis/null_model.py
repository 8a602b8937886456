"""The diagnosis's null model learns what a lab does not know.

What a laboratory cannot state to the precision a simulator fixes it becomes
a nuisance of the baseline, estimated from the campaign itself *before any
effect is considered* and reported in the diagnosis (``nuisances`` in its
JSON).  This module holds the tone-side part, learnt once per campaign:

* the spectrum analyser's noise floor (:func:`dpdfit.fits.tone_noise.estimate_noise_floor`
  when ``spectra.csv`` has no ``snr_db``), which debiases the tone powers
  and sets their noise errors;
* the repeatability of a recorded tone power ``s_tone`` (dB, independent per
  tone) from the second differences of the baseline's residuals of every
  within-trace feature (:func:`dpdfit.fits.tone_noise.robust_scale`);
* the laser-power jitter of a trace ``s_trace`` (dB, common to its tones),
  the same way from the ``gate_power`` feature.

Second differences along A cancel any smooth misfit, so these scales are
those of the noise whatever effect the baseline lacks; they are then held
fixed for every hypothesis (baseline and effects), so that all are judged
against the same errors.  The gate-side nuisances (preparation split,
detection errors, rate-calibration scatter) are fitted with the baseline:
see :mod:`dpdfit.analyses.diagnosis.gate_model` and
:mod:`dpdfit.analyses.diagnosis.rate_scatter`.

Priors (documented bounds; the estimates are clipped into them):
``s_tone`` in [``S_TONE_MIN``, ``S_TONE_MAX``] dB, ``s_trace`` in
[0, ``S_TRACE_MAX``] dB.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dpdfit.analyses.diagnosis.observables import (TONE_FEATURES, TONE_HARMONICS, Campaign,
                                                   debias_tones, tone_features)
from dpdfit.fits.tone_noise import NoiseFloor, estimate_noise_floor, floor_from_snr, robust_scale

__all__ = ["GATE", "ToneNoise", "learn_tone_noise", "S_TONE_MIN", "S_TONE_MAX", "S_TRACE_MAX"]

#: repeatability of a recorded tone power: lower bound (the forward model's own accuracy:
#: its 4x-oversampled grid and the 4096-point table agree with a finer model to ~0.005 dB)
S_TONE_MIN = 0.005
S_TONE_MAX = 0.5
S_TRACE_MAX = 2.0
#: gate tones of the Cardioid(1,2) waveform
GATE = (1, 2)


@dataclass(frozen=True)
class ToneNoise:
    """Tone-side noise learnt from the campaign (see module doc)."""

    floor: NoiseFloor
    s_tone_db: float
    s_trace_db: float
    n_second_differences: int

    def to_dict(self) -> dict:
        """The noise as a JSON-ready dict: ``noise_floor``, ``tone_repeatability_db``,
        ``trace_power_jitter_db``, ``n_second_differences``."""
        return {"noise_floor": self.floor.to_dict(), "tone_repeatability_db": self.s_tone_db,
                "trace_power_jitter_db": self.s_trace_db,
                "n_second_differences": self.n_second_differences}


def _second_differences(r: np.ndarray, v: np.ndarray):
    """Squared second differences along axis 0 and their known variances (finite triples)."""
    d = r[:-2] - 2 * r[1:-1] + r[2:]
    vd = v[:-2] + 4 * v[1:-1] + v[2:]
    ok = np.isfinite(d) & np.isfinite(vd)
    return d[ok] ** 2, vd[ok]


def learn_tone_noise(camp: Campaign, model_features: dict):
    """Debiased tone powers, their errors and the learnt :class:`ToneNoise`.

    ``model_features``: the baseline model's features (``ToneModel.features({})``).

    Returns
    -------
    (P_dB, sd_dB, noise)
        ``sd_dB`` is the total per-tone error, ``hypot(noise part, s_tone)``.
    """
    A = camp.A_tones
    if camp.has_snr:
        P, sd_noise = camp.P_dB, camp.sd_dB
        floor = floor_from_snr(camp.P_raw, camp.snr_raw)
    else:
        im = np.array([h not in GATE for h in TONE_HARMONICS])
        im = np.broadcast_to(im, camp.P_raw.shape[1:])
        floor = estimate_noise_floor(camp.P_raw, A, im)
        P, sd_noise = debias_tones(camp.P_raw, floor.N0)
    # repeatability from the per-trace differences (the trace's power jitter cancels)
    feats = tone_features(P, A, sd_noise)
    d2s, vds, ks = [], [], []
    for name, (per_sb, _) in TONE_FEATURES.items():
        if name == "gate_power":
            continue
        v, e = feats[name]
        r = v - model_features[name]
        a, b = _second_differences(r, e ** 2)
        m = 2.0 if per_sb else 1.0                     # s_tone^2 multiples in one residual
        d2s.append(a), vds.append(b), ks.append(np.full(a.size, 6 * m))
    d2, vd, k = (np.concatenate(x) for x in (d2s, vds, ks))
    s_tone = robust_scale(d2, vd, k)
    s_tone = float(np.clip(s_tone if np.isfinite(s_tone) else S_TONE_MIN, S_TONE_MIN, S_TONE_MAX))
    sd = np.hypot(sd_noise, s_tone)
    # the trace's power jitter from gate_power (mean of the 4 gate tones)
    v, e = tone_features(P, A, sd)["gate_power"]
    r = v - model_features["gate_power"]
    a, b = _second_differences(r, e ** 2)
    s_trace = robust_scale(a, b, np.full(a.size, 6.0))
    s_trace = float(np.clip(s_trace if np.isfinite(s_trace) else 0.0, 0.0, S_TRACE_MAX))
    return P, sd, ToneNoise(floor, s_tone, s_trace, int(d2.size))
