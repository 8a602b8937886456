"""The detector linearity characterisation (``detector_linearity.csv``) as data of every
hypothesis: the calibration photodiode read with and without a calibrated attenuator.

Its prediction is the effects' own photodiode
(:meth:`~dpdfit.analyses.diagnosis.effects.base.Effect.detector_reading`, the function
whose inverse a detector nonlinearity's transfer applies to the calibration): the plain
reading ``P`` is the detector's reading of a true power ``u_t P_max`` (``P_max`` the
amplitude curve's largest reading, the scale of the effect's ``k``), the attenuated one
the detector's reading of ``T u_t P_max``, ``T = 10^(-attenuation_db/10)``.  So with a
linear photodiode the attenuated reading is ``T P`` whatever the AOM did (a stale table
moves ``P``, not the ratio), and only an effect that changes the detector's reading
changes it.

Each pair gives one standardised residual, the attenuated reading's deviation over its
noise with the plain reading's propagated: ``(P_att - pred) / sqrt(s_att^2 + (pred/P
s)^2)`` (the noise of each reading:
:mod:`~dpdfit.analyses.diagnosis.observables.detector_linearity`).
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.effects import EFFECTS

__all__ = ["predicted_attenuated", "linearity_block"]


def _reading(ctx, p: dict, u: np.ndarray, inverse: bool) -> np.ndarray:
    """The detector's reading of true relative powers ``u`` (``inverse``: the true power of
    readings ``u``) under the effects present in ``p``, in the registry's order."""
    present = {k.partition(".")[0] for k in p if "." in k}
    effects = [e for e in EFFECTS.values() if e.name in present]
    for e in (reversed(effects) if inverse else effects):
        v = e.values(p)
        if v is not None:
            u = e.detector_reading(ctx.tone, v, u, inverse)
    return u


def predicted_attenuated(ctx, p: dict, power, transmission) -> np.ndarray:
    """The attenuated readings (lab units) of plain readings ``power`` through an
    attenuator of ``transmission``, at the parameter set ``p`` (module doc)."""
    scale = float(ctx.tone.P_max)
    u_true = _reading(ctx, p, np.asarray(power, dtype=float) / scale, inverse=True)
    return scale * _reading(ctx, p, np.asarray(transmission, dtype=float) * u_true,
                            inverse=False)


def linearity_block(ctx, p: dict) -> tuple:
    """``(label, z)``: the standardised residuals of ``ctx.camp.detector_linearity`` (one
    per reading pair) at the parameter set ``p``."""
    t = ctx.camp.detector_linearity.table
    power = t["power"].to_numpy()
    pred = predicted_attenuated(ctx, p, power, t["transmission"].to_numpy())
    slope = pred / np.maximum(power, 1e-300)
    sd = np.sqrt(t["sigma_attenuated"].to_numpy() ** 2 + (slope * t["sigma"].to_numpy()) ** 2)
    z = (t["power_attenuated"].to_numpy() - pred) / sd
    return {"kind": "linearity", "observable": "detector_linearity"}, z
