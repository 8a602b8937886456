"""The null model: what the baseline learns from a campaign before any effect is
considered, where the lab does not state it.

* the tone-side noise (floor, repeatability, trace power jitter:
  :func:`~dpdfit.analyses.diagnosis.model.tones.tone_noise.learn_tone_noise`);
* the sign convention of the recorded phase response, which the tone powers do not fix
  and the gates choose (:func:`choose_phase_sign`);
* the gate-rate calibration's relative scatter
  (:func:`~dpdfit.analyses.diagnosis.model.gates.rate_scatter.learn_rate_scatter`).

:class:`NullModel` states what was learnt (the JSON's ``null_model``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dpdfit.analyses.diagnosis.model.tones.tone_noise import ToneNoise
from dpdfit.core.records import Record

__all__ = ["NullModel", "choose_phase_sign"]


@dataclass(frozen=True)
class NullModel(Record):
    """What the baseline learnt from the campaign before any effect."""

    #: the tone-side noise (floor, repeatability, trace power jitter)
    tone_noise: ToneNoise
    #: the calibration runs' noise models, as the campaign's reader learnt them
    calibration_noise: dict
    #: the sign convention of the recorded phase response (None without a phase file)
    phase_sign: int | None
    #: the gates' chi2 under either sign, ``{"+1": chi2, "-1": chi2}`` (None: not chosen)
    phase_sign_chi2: dict | None
    #: the gate-rate calibration's relative scatter, learnt (None without gates)
    rate_scatter: dict | None
    #: the per-scan laser-power jitter of the gate model (dB; None without gates)
    per_scan_power_jitter_db: float | None
    #: the lab's total preparation error per ion (None without gates)
    preparation_error_total: float | None
    #: the baseline's fitted nuisances, the calibration modes left out (None: not fitted)
    fitted: dict | None = None
    #: the coherence time recorded by ``ramsey.csv`` beside the lab's stated one
    #: (:func:`~dpdfit.analyses.diagnosis.model.ramsey_block.coherence_report`; None
    #: without the file)
    coherence: dict | None = None
    #: where the detector linearity characterisation's noise comes from (one phrase,
    #: :mod:`~dpdfit.analyses.diagnosis.observables.detector_linearity`; None without
    #: ``detector_linearity.csv``)
    detector_linearity_noise: str | None = None
    #: with thermometry: the motional state the baseline recorded, ``nbar`` and
    #: ``heating_q_per_ms``, each ``{"recorded", "error", "stated"}``
    #: (:func:`~dpdfit.analyses.diagnosis.model.thermometry_block.recorded_motion`; None
    #: without thermometry, and then not in the JSON)
    recorded_motion: dict | None = None

    def to_dict(self) -> dict:
        """The JSON's ``null_model``: every attribute, ``tone_noise`` as its dict;
        ``fitted`` only once the baseline is fitted, ``coherence`` only with
        ``ramsey.csv``, ``detector_linearity_noise`` only with a detector linearity
        table."""
        out = {"tone_noise": self.tone_noise.to_dict(),
               "calibration_noise": dict(self.calibration_noise),
               "phase_sign": self.phase_sign, "phase_sign_chi2": self.phase_sign_chi2,
               "rate_scatter": self.rate_scatter,
               "per_scan_power_jitter_db": self.per_scan_power_jitter_db,
               "preparation_error_total": self.preparation_error_total}
        if self.fitted is not None:
            out["fitted"] = dict(self.fitted)
        if self.coherence is not None:
            out["coherence"] = dict(self.coherence)
        if self.detector_linearity_noise is not None:
            out["detector_linearity_noise"] = self.detector_linearity_noise
        if self.recorded_motion is not None:
            out["recorded_motion"] = {k: dict(v) for k, v in self.recorded_motion.items()}
        return out


def _gate_chi2(prob) -> float:
    """Gate and time-scan chi2 of the baseline, the preparation split profiled on a grid."""
    best = np.inf
    for f in np.linspace(0.0, 1.0, 11):
        z = [zz for lab, zz in prob.blocks({"prep_split": f}, with_prior=False,
                                            with_tones=False)]
        z = np.concatenate([np.ravel(x) for x in z])
        best = min(best, float(np.sum(z[np.isfinite(z)] ** 2)))
    return best


def choose_phase_sign(prob) -> dict:
    """The sign convention of the recorded phase response, chosen by the gates; returns
    both signs' gate chi2 ``{"+1": ..., "-1": ...}`` and leaves ``prob`` with the models
    of the chosen sign.

    The tone powers are the same for both signs
    (:meth:`~dpdfit.analyses.diagnosis.model.tones.tone_model.ToneModel.with_phase_sign`);
    the gates are not.  Both baselines' means are evaluated (the other sign's two-ion
    branch only: the single-ion branches of the preparation errors weigh ~1e-3 and are
    kept; all of them when that sign is kept; the effect responses are then computed once
    for the chosen sign) and the one with the smaller gate chi2 is kept.
    """
    plus = _gate_chi2(prob)
    alt_tone = prob.tone.with_phase_sign(-1)
    keep = prob.gate
    prob.gate = keep.rebased(alt_tone, {}, two_ion_only=True)
    minus = _gate_chi2(prob)
    if minus < plus:
        prob.use_tone(alt_tone)
        prob.gate = keep.rebased(alt_tone, {})
    else:
        prob.gate = keep
    return {"+1": plus, "-1": minus}
