"""The discrepancy diagnosis: forward model of a campaign's observables, null model, candidate
effects, fits and verdict.

Modules, in the order the diagnosis uses them: :mod:`.observables` (the recordings,
standardised), :mod:`.tone_model` and :mod:`.gate_model` (the forward models),
:mod:`.null_model` and :mod:`.rate_scatter` (what the lab does not state, learnt first),
:mod:`.problem` (observables, nuisances and residuals), :mod:`.effects` (the catalog, one
module per effect), :mod:`.mode_profile` and :mod:`.fitting` (the fit of one hypothesis),
:mod:`.phase_sign` (a tone-side effect carried over to the gates), :mod:`.scan` and
:mod:`.verdict` (located mismatches, ranking, verdict), :mod:`.result` (:class:`Diagnosis`)
and :mod:`.diagnose` (the entry point, :func:`~.diagnose.diagnose`).
"""

__all__: list[str] = []
