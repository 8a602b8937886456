"""The fit of one hypothesis (the baseline, an effect, several) to every observable: the
least-squares problem (:mod:`.least_squares`) with the calibration's error modes solved
linearly (:mod:`.variable_projection`), the fit itself (:mod:`.hypothesis_fit`) and its
result (:mod:`.fit_result`), a tone-side fit carried over to the gates
(:mod:`.phase_sign`) and profile-likelihood intervals where the curvature fails
(:mod:`.likelihood_intervals`).
"""

__all__: list[str] = []
