"""The model of a campaign: the forward models of its tone powers (:mod:`.tones`) and
gate observables (:mod:`.gates`), the nuisances a lab does not state, learnt before any
effect (the null model), the residuals of every observable at a parameter set
(:mod:`.residuals`, :class:`~.residuals.Problem`) and the free parameters a fit of it
varies, each with its value, bounds and scale (:mod:`.parameters`).
"""

__all__: list[str] = []
