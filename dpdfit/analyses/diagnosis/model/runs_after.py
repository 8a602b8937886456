"""The calibration runs taken after the recordings as data of every hypothesis: the drift
the effects present predict for them (:func:`run_drift`) and their standardised residuals
(:func:`runs_after_block`).

The runs' coordinates along the run-to-run drift modes are recorded
(:class:`~dpdfit.analyses.diagnosis.observables.calibration_drift.RunsAfter`); under the
baseline they scatter about the runs taken before the recordings, and an effect that
moves them (a drifted AOM: :meth:`~dpdfit.analyses.diagnosis.effects.base.Effect.run_drift`)
shifts them.
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.effects import EFFECTS

__all__ = ["run_drift", "runs_after_block"]


def run_drift(ctx, p: dict, days) -> np.ndarray:
    """Shift ``(len(days), n modes)`` of calibration runs taken ``days`` after the
    recordings, in the drift modes' sd, that the effects present in the parameter set
    ``p`` predict (``ctx``: the diagnosis's problem)."""
    shift = np.zeros((len(days), len(ctx.tone.drift_modes)))
    # the effects whose parameters ``p`` holds (``"<effect>.<param>"``), in the registry's
    # order: a fit asks this at every evaluation, and most effects are absent
    present = {k.partition(".")[0] for k in p if "." in k}
    for e in EFFECTS.values():
        if e.name not in present:
            continue
        v = e.values(p)
        if v is not None:
            s = e.run_drift(ctx, v, days)
            if s is not None:
                shift = shift + s
    return shift


def runs_after_block(ctx, p: dict) -> tuple:
    """``(label, z)``: the standardised residuals of the runs taken after the recordings
    (``ctx.runs_after``) at the parameter set ``p``."""
    ra = ctx.runs_after
    shift = run_drift(ctx, p, ra.days)
    return ({"kind": "runs", "observable": "calibration_after"},
            ra.standardised(shift).ravel())
