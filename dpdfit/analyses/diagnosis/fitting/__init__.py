"""The fit of one hypothesis (the baseline, an effect, several) to every observable: the
least-squares problem (:mod:`~dpdfit.analyses.diagnosis.fitting.least_squares`) with the calibration's error modes solved
linearly (:mod:`~dpdfit.analyses.diagnosis.fitting.variable_projection`), the fit itself (:mod:`~dpdfit.analyses.diagnosis.fitting.hypothesis_fit`) and its
result (:mod:`~dpdfit.analyses.diagnosis.fitting.fit_result`), a tone-side fit carried over to the gates
(:mod:`~dpdfit.analyses.diagnosis.fitting.phase_sign`) and profile-likelihood intervals where the curvature fails
(:mod:`~dpdfit.analyses.diagnosis.fitting.likelihood_intervals`).
"""

__all__: list[str] = []
