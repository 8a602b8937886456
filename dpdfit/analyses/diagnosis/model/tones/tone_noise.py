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
those of the noise whatever effect the baseline lacks (a tone or a trace pooled
from repeated recordings enters with its share, ``1/k``, of the unknown
variance, so the scales are those of one reading and one trace); they are then held
fixed for every hypothesis (baseline and effects), so that all are judged
against the same errors.  The gate-side nuisances (preparation split,
detection errors, rate-calibration scatter) are fitted with the baseline:
see :mod:`dpdfit.analyses.diagnosis.model.gates.gate_model` and
:mod:`dpdfit.analyses.diagnosis.model.gates.rate_scatter`.

Priors (documented bounds; the estimates are clipped into them):
``s_tone`` in [``S_TONE_MIN``, ``S_TONE_MAX``] dB, ``s_trace`` in
[0, ``S_TRACE_MAX``] dB.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dpdfit.analyses.diagnosis.observables.campaign import Campaign
from dpdfit.analyses.diagnosis.observables.tone_features import (TONE_FEATURES,
                                                                 TONE_HARMONICS,
                                                                 debias_tones,
                                                                 tone_features)
from dpdfit.fits.tone_noise import (NoiseFloor, estimate_noise_floor, floor_from_snr,
                                    robust_scale)

__all__ = ["GATE", "ToneNoise", "learn_tone_noise", "repeats_of", "trace_jitter_multiple",
           "S_TONE_MIN", "S_TONE_MAX", "S_TRACE_MAX"]

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


def _second_differences(r: np.ndarray, v: np.ndarray, w: np.ndarray):
    """Squared second differences along axis 0, their known variances and the multiples
    of the unknown variance in them (finite triples): ``v`` the known variance of each
    residual, ``w`` the multiple of the unknown variance ``s^2`` in it."""
    d = r[:-2] - 2 * r[1:-1] + r[2:]
    vd = v[:-2] + 4 * v[1:-1] + v[2:]
    kd = w[:-2] + 4 * w[1:-1] + w[2:]
    ok = np.isfinite(d) & np.isfinite(vd) & np.isfinite(kd)
    return d[ok] ** 2, vd[ok], kd[ok]


def repeats_of(camp: Campaign) -> np.ndarray:
    """Readings pooled into each tone (``Campaign.n_repeats``; 1 each when not given),
    NaN where a tone has none."""
    n = np.ones(camp.P_raw.shape) if camp.n_repeats is None else np.asarray(camp.n_repeats,
                                                                            dtype=float)
    return np.where(n > 0, n, np.nan)


def trace_jitter_multiple(n: np.ndarray) -> np.ndarray:
    """Multiple of a trace's power-jitter variance in the ``gate_power`` feature (mean of
    the 4 gate tones) of pooled repeats, shape (nA, 2 dpd, 1).

    ``n``: readings per tone (:func:`repeats_of`).  A sideband pooled from ``k`` repeat
    traces carries the mean of their jitters (variance ``s^2 / k``); the red and the
    blue tones of one repeat come from one trace, so with ``k_r`` and ``k_b`` repeats the
    mean of the sidebands has ``0.25/k_r + 0.25/k_b + 0.5 min(k_r, k_b)/(k_r k_b)``
    (1/k for ``k`` repeats of both, 1 for one trace).
    """
    gate = np.where(np.isin(TONE_HARMONICS, GATE) & np.isfinite(n), n, 0.0)
    k = gate.max(axis=-1)                                           # (nA, 2, 2)
    k = np.where(k > 0, k, np.nan)
    kr, kb = k[..., 0], k[..., 1]
    return (0.25 / kr + 0.25 / kb + 0.5 * np.minimum(kr, kb) / (kr * kb))[..., None]


def learn_tone_noise(camp: Campaign, model_features: dict):
    """Debiased tone powers, their errors and the learnt :class:`ToneNoise`.

    ``model_features``: the baseline model's features (``ToneModel.features({})``).
    A tone pooled from ``k`` repeated readings (``Campaign.n_repeats``) has ``1/k`` of a
    reading's noise variance, floor part and repeatability alike, and a trace pooled from
    ``k`` repeats ``1/k`` of its power jitter (:func:`trace_jitter_multiple`): the second
    differences weigh each point's unknown variance by those multiples, so the learnt
    scales stay those of one reading and one trace.

    Returns
    -------
    (P_dB, sd_dB, noise)
        ``sd_dB`` is the total per-tone error, ``hypot(noise part, s_tone / sqrt(k))``.
    """
    A = camp.A_tones
    n = repeats_of(camp)
    if camp.has_snr:
        P, sd_noise = camp.P_dB, camp.sd_dB
        floor = floor_from_snr(camp.P_raw, camp.snr_raw)
    else:
        im = np.array([h not in GATE for h in TONE_HARMONICS])
        im = np.broadcast_to(im, camp.P_raw.shape[1:])
        # every reading, not their means: the floor's likelihood is that of one reading
        each = camp.P_raw[:, None] if camp.P_readings is None else camp.P_readings
        floor = estimate_noise_floor(each.reshape((-1,) + each.shape[2:]),
                                     np.repeat(A, each.shape[1]), im)
        P, sd_noise = debias_tones(camp.P_raw, floor.N0, np.nan_to_num(n, nan=1.0))
    # repeatability from the per-trace differences (the trace's power jitter cancels);
    # the features of 1/sqrt(k) are the square roots of the s_tone^2 multiples
    feats = tone_features(P, A, sd_noise)
    mults = tone_features(np.zeros_like(P), A, 1 / np.sqrt(n))
    d2s, vds, ks = [], [], []
    for name in TONE_FEATURES:
        if name == "gate_power":
            continue
        v, e = feats[name]
        a, b, k = _second_differences(v - model_features[name], e ** 2, mults[name][1] ** 2)
        d2s.append(a), vds.append(b), ks.append(k)
    d2, vd, k = (np.concatenate(x) for x in (d2s, vds, ks))
    s_tone = robust_scale(d2, vd, k)
    s_tone = float(np.clip(s_tone if np.isfinite(s_tone) else S_TONE_MIN, S_TONE_MIN, S_TONE_MAX))
    sd = np.hypot(sd_noise, s_tone / np.sqrt(n))
    # the trace's power jitter from gate_power (mean of the 4 gate tones)
    v, e = tone_features(P, A, sd)["gate_power"]
    a, b, k = _second_differences(v - model_features["gate_power"], e ** 2,
                                  trace_jitter_multiple(n))
    s_trace = robust_scale(a, b, k)
    s_trace = float(np.clip(s_trace if np.isfinite(s_trace) else 0.0, 0.0, S_TRACE_MAX))
    return P, sd, ToneNoise(floor, s_tone, s_trace, int(d2.size))
