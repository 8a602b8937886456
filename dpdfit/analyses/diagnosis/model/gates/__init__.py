"""The gate side of the model: the exact engine's runs at every gate setting
(:mod:`~dpdfit.analyses.diagnosis.model.gates.engine_runs`), the responses to the effects' knobs and to the power
(:mod:`~dpdfit.analyses.diagnosis.model.gates.knob_response`), what the effects present change (:mod:`~dpdfit.analyses.diagnosis.model.gates.effect_terms`), the
measured probabilities and fringes (:mod:`~dpdfit.analyses.diagnosis.model.gates.observe`), all put together by
:class:`~dpdfit.analyses.diagnosis.model.gates.gate_model.GateModel`, and the whitened residuals of the gate observables
(:mod:`~dpdfit.analyses.diagnosis.model.gates.gate_residuals`, :mod:`~dpdfit.analyses.diagnosis.model.gates.whitening`); and the gate-rate calibration's
scatter the null model learns (:mod:`~dpdfit.analyses.diagnosis.model.gates.rate_scatter`).
"""

__all__: list[str] = []
