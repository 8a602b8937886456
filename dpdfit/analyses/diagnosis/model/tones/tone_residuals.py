"""The standardised residuals of the tone side: each trace's tone features against the
tone model's, with the tone noise the null model learnt (:class:`ToneResiduals`)."""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.model.tones.tone_model import ToneModel
from dpdfit.analyses.diagnosis.observables.tone_features import tone_features

__all__ = ["ToneResiduals"]


class ToneResiduals:
    """The recorded tone features of a campaign (``{feature: (value, error)}`` of
    :func:`~dpdfit.analyses.diagnosis.observables.tone_features.tone_features`) and their
    standardised residuals against a tone model.

    ``sig_jit``: one trace's power jitter (dB) and ``jit_multiple``: the share of it each
    (pooled) trace carries, both for the absolute scale ``gate_power``, which is
    profiled (a weighted mean).
    """

    def __init__(self, P_dB, A, sd_dB, sig_jit: float, jit_multiple):
        self.meas = tone_features(P_dB, A, sd_dB)
        self.sig_jit = float(sig_jit)
        self.jit_multiple = jit_multiple
        self._key, self._model, self._blocks = None, None, None

    def reset(self) -> None:
        """Forget the model's last features (the tone model in use changed)."""
        self._key = None

    def feature_blocks(self, tone: ToneModel, p: dict) -> list:
        """``[(label, z)]`` of every tone feature at the tone-side parameters ``p`` of the
        tone model ``tone``.  The blocks of the last parameter set are kept (read-only
        arrays): the gate side's Jacobian columns ask for them again unchanged."""
        key = tuple(sorted((k, float(v)) for k, v in p.items()))
        if key != self._key:
            self._key, self._model = None, tone.features(p)
            self._blocks = self._standardised(self._model)
            self._key = key
        return [(dict(label), z) for label, z in self._blocks]

    def _standardised(self, model: dict) -> list:
        """``[(label, z)]`` of the model's features ``model`` against the recorded ones."""
        out = []
        for name, (v, e) in self.meas.items():
            m = model[name]
            if name == "gate_power":
                # absolute scale of the tone powers: profiled (weighted mean), 1 parameter
                e = np.sqrt(e ** 2 + self.sig_jit ** 2 * self.jit_multiple)
                r = v - m
                ok = np.isfinite(r)
                m = m + (np.sum(r[ok] / e[ok] ** 2) / np.sum(1 / e[ok] ** 2) if ok.any() else 0)
            z = (v - m) / e
            z.flags.writeable = False
            out.append(({"kind": "tones", "observable": name}, z))
        return out
