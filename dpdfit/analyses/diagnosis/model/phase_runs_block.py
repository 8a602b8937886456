"""The phase runs taken after the recordings as data of every hypothesis: the phase the
model's transfer predicts for them (:func:`recorded_phase`) and their whitened residuals
(:func:`phase_runs_block`).

A phase run measures the AOM's phase transfer ``phi(A)`` (relative to weak drive, in the
sign convention of ``phase_rad``).  The forward model's phase curve is the model run's
calibration with its error modes (``cal_phase*``) and the coefficients the effects present
change (:meth:`~dpdfit.analyses.diagnosis.effects.base.Effect.coefficients`: the
modulator's own AM-to-PM left out of the model); it enters the field as
``exp(sign i phi)`` (the phase-sign convention the null model chose), so a run records
``sign`` times it.  A phase-odd parameter changes sign with the convention, so the
prediction does not depend on it.  A phase after the AOM (the beam path: no effect's
coefficients) is not seen by a phase run of the AOM.
"""

from __future__ import annotations

import numpy as np

__all__ = ["recorded_phase", "phase_runs_block"]


def recorded_phase(tone, p: dict, A) -> np.ndarray:
    """The phase (rad, as a run records it) of the forward model ``tone``'s phase
    transfer at the parameter set ``p`` and drive amplitudes ``A``."""
    cp = tone.coefficients(p)[1]
    A = np.asarray(A, dtype=float)
    return tone.phase_sign * (np.polynomial.polynomial.polyval(A, cp) - cp[0])


def phase_runs_block(ctx, p: dict) -> tuple:
    """``(label, z)``: the whitened residuals of the phase runs taken after the recordings
    (``ctx.camp.phase_runs_after``) at the parameter set ``p`` (``ctx``: the diagnosis's
    problem)."""
    runs = ctx.camp.phase_runs_after
    z = runs.standardised(lambda A: recorded_phase(ctx.tone, p, A))
    return {"kind": "phase_runs", "observable": "calibration_phase_after"}, z
