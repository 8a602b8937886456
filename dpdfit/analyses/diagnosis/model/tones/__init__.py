"""The tone side of the model: a campaign's tone powers predicted from its own calibration
(:mod:`.tone_model`, with the envelope engine of :mod:`.envelope` and the interpolation of
:mod:`.interpolation`), the residuals of the tone features (:mod:`.tone_residuals`) and the
tone noise the null model learns (:mod:`.tone_noise`).
"""

__all__: list[str] = []
