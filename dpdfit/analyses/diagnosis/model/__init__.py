"""The model of a campaign: the forward models of its tone powers (:mod:`~dpdfit.analyses.diagnosis.model.tones`) and
gate observables (:mod:`~dpdfit.analyses.diagnosis.model.gates`), the nuisances a lab does not state, learnt before any
effect (the null model), the residuals of every observable at a parameter set
(:mod:`~dpdfit.analyses.diagnosis.model.residuals`, :class:`~dpdfit.analyses.diagnosis.model.residuals.Problem`) and the free parameters a fit of it
varies, each with its value, bounds and scale (:mod:`~dpdfit.analyses.diagnosis.model.parameters`).
"""

__all__: list[str] = []
