"""The tone side of the model: a campaign's tone powers predicted from its own calibration
(:mod:`~dpdfit.analyses.diagnosis.model.tones.tone_model`, with the envelope engine of :mod:`~dpdfit.analyses.diagnosis.model.tones.envelope` and the interpolation of
:mod:`~dpdfit.analyses.diagnosis.model.tones.interpolation`), the residuals of the tone features (:mod:`~dpdfit.analyses.diagnosis.model.tones.tone_residuals`) and the
tone noise the null model learns (:mod:`~dpdfit.analyses.diagnosis.model.tones.tone_noise`).
"""

__all__: list[str] = []
