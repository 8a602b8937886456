"""The recordings of a campaign, standardised for the diagnosis: what the forward models
predict, each with a 1-sigma error holding every known noise source and nothing else.

:mod:`~dpdfit.analyses.diagnosis.observables.campaign` reads a campaign folder into a :class:`~dpdfit.analyses.diagnosis.observables.campaign.Campaign` (the
calibrations, the gate observables, the time scans); :mod:`~dpdfit.analyses.diagnosis.observables.tone_features` turns tone
powers into per-trace features; :mod:`~dpdfit.analyses.diagnosis.observables.tone_grid` puts the spectra on the diagnosis's
grid; :mod:`~dpdfit.analyses.diagnosis.observables.calibration_drift` holds the run-to-run drift of the amplitude calibration
and the runs taken after the recordings.
"""

__all__: list[str] = []
