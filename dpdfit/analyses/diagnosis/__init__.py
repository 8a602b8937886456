"""The discrepancy diagnosis: locate where a campaign's recordings and its simulation
disagree, name the missing physics, size it and show the fit improve.

The folders follow the data, each stage reading only the ones above it::

    observables/   the recordings of a campaign, standardised with their errors
    effects/       the catalog: one module per effect, what the diagnosis fits
    model/         the residuals of every observable: forward models, nuisances, null model
      tones/       the tone powers' forward model and the tone noise
      gates/       the gate observables' forward model (exact engine) and the rate scatter
    fitting/       the fit of one hypothesis (the baseline, an effect, several)
    evidence/      what the fits say: mismatches, ranking, tempering, families, thresholds
    decisions/     the verdict: first effect, additions, explanations, alternatives, upper limits
    proposal/      the next recording: hypotheses in reach, menu, separation, schedule
    comparison/    what a further recording changed, against an earlier diagnosis
    result.py      Diagnosis, the typed result and its JSON (rendering.py: its text)
    diagnose.py    diagnose(), the stages in order

:func:`~dpdfit.analyses.diagnosis.diagnose.diagnose` is the entry point.
"""

__all__: list[str] = []
