"""The tone side of the model: a campaign's tone powers predicted from its own calibration
(:mod:`.tone_model`, with the envelope engine of :mod:`.envelope` and the interpolation of
:mod:`.interpolation`), the tone-side effects present in a parameter set
(:mod:`.active_effects`) and the tone noise the null model learns (:mod:`.tone_noise`).
"""

__all__: list[str] = []
