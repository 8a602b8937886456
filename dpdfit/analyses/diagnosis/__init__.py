"""The discrepancy diagnosis: forward model of a campaign's observables, null model, candidate
effects, fits and verdict.

Modules, in the order the diagnosis uses them: :mod:`~dpdfit.analyses.diagnosis.observables.campaign.campaign` (the recordings,
standardised), :mod:`~dpdfit.analyses.diagnosis.model.tones.tone_model` and :mod:`~dpdfit.analyses.diagnosis.model.gates.gate_model` (the forward models),
:mod:`~dpdfit.analyses.diagnosis.model.tones.tone_noise` and :mod:`~dpdfit.analyses.diagnosis.model.gates.rate_scatter` (what the lab does not state, learnt first),
:mod:`~dpdfit.analyses.diagnosis.model.residuals` (observables, nuisances and residuals), :mod:`~dpdfit.analyses.diagnosis.effects` (the catalog, one
module per effect), :mod:`~dpdfit.analyses.diagnosis.fitting.hypothesis_fit.variable_projection` and :mod:`~dpdfit.analyses.diagnosis.fitting.hypothesis_fit.hypothesis_fit` (the fit of one hypothesis),
:mod:`~dpdfit.analyses.diagnosis.fitting.hypothesis_fit.phase_sign` (a tone-side effect carried over to the gates), :mod:`~dpdfit.analyses.diagnosis.evidence.deviations` and
:mod:`~dpdfit.analyses.diagnosis.evidence.mismatches` (located mismatches, ranking, verdict), :mod:`~dpdfit.analyses.diagnosis.result` (:class:`Diagnosis`)
and :mod:`~dpdfit.analyses.diagnosis.diagnose` (the entry point, :func:`~dpdfit.analyses.diagnosis.diagnose.diagnose`).
"""

__all__: list[str] = []
