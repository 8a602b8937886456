"""The gate side of the model: the exact engine's runs at every gate setting
(:mod:`.engine_runs`), the responses to the effects' knobs and to the power
(:mod:`.knob_response`), what the effects present change (:mod:`.effect_terms`), the
measured probabilities and fringes (:mod:`.observe`), all put together by
:class:`~.gate_model.GateModel`, and the whitened residuals of the gate observables
(:mod:`.gate_residuals`, :mod:`.whitening`); and the gate-rate calibration's
scatter the null model learns (:mod:`.rate_scatter`).
"""

__all__: list[str] = []
