"""The sideband thermometry (``thermometry.csv``) as data of every hypothesis: the gate mode
probed on its red or blue sideband after a variable wait.

Its prediction is :mod:`dpdfit.models.sideband_thermometry` (the thermal average of the
sideband Rabi flopping of a fixed probe pulse: the simulator's own physics) at the mean
occupation ``nbar0 + ndot t`` of the gate model (:func:`motional_state`: the lab's
stated ``nbar`` and heating rate, moved by every active effect's knobs exactly as the
gate engine's inputs are moved, the knob's ``perturb``
(:class:`~dpdfit.analyses.diagnosis.effects.base.Knob`) with the effect's
:meth:`~dpdfit.analyses.diagnosis.effects.base.Effect.knob_coefficients`; with
thermometry also by the baseline's recorded motional state,
:mod:`~dpdfit.analyses.diagnosis.model.recorded_motion`), read through the gate model's preparation and detection errors
(:meth:`~dpdfit.analyses.diagnosis.model.gates.gate_model.GateModel.preparation`).  So an
effect that heats the mode or adds initial phonons is constrained by it, one that acts on
the coherence (dephasing) or the drive is not, and a SPAM offset only through the
readout.

The counts of a point are binomial (bright, dark); its residuals are the signed deviance
residuals of :func:`~dpdfit.analyses.diagnosis.model.spam_block.deviance_residuals`.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from dpdfit.analyses.diagnosis.model.gates.effect_terms import active_effects, weights
from dpdfit.analyses.diagnosis.model.spam_block import deviance_residuals
from dpdfit.models.sideband_thermometry import bright_probability, mean_occupation

__all__ = ["motional_state", "thermometry_probabilities", "thermometry_block",
           "recorded_motion"]

#: the gate engine's inputs that are the mode's motional state
_MOTION = ("nbar", "ndot")


def _moves_motion(knob, nominal: dict) -> bool:
    """Whether ``knob`` moves the motional state (tried at its own step, as the gate
    engine runs it; a coherence knob does not, and is not evaluated off its range)."""
    moved = knob.perturb(nominal, knob.step)
    return any(float(moved[k]) != float(nominal[k]) for k in _MOTION)


def motional_state(gm, p: dict, active=None) -> tuple:
    """``(nbar0, ndot)`` (quanta, quanta/s) of the gate mode at parameters ``p``: the gate
    model ``gm``'s nominal values moved by the ``active`` effects' knobs (at the model's
    reference gate time and amplitude: a heating knob's weight does not depend on them)."""
    active = active_effects(gm.effects, p) if active is None else active
    nominal = gm.nominal
    nbar, ndot = float(nominal["nbar"]), float(nominal["ndot"])
    coefs, _ = weights(gm, active, np.array([gm.t_ref]), np.array([gm.A_ref]))
    for key, c in coefs.items():
        c, knob = float(np.mean(c)), gm.knobs[key]
        if c == 0.0 or not _moves_motion(knob, nominal):
            continue
        moved = knob.perturb(nominal, c)
        nbar += float(moved["nbar"]) - float(nominal["nbar"])
        ndot += float(moved["ndot"]) - float(nominal["ndot"])
    return nbar, ndot


def thermometry_probabilities(gm, p: dict, wait_s, sideband) -> np.ndarray:
    """Probability that the probed ion reads bright at each point (``wait_s`` in s, one
    ``sideband`` each), at parameters ``p`` of the gate model ``gm`` (module doc)."""
    active = active_effects(gm.effects, p)
    nbar, ndot = motional_state(gm, p, active)
    prep = gm.preparation(p, active)
    return bright_probability(mean_occupation(nbar, ndot, wait_s), np.asarray(sideband),
                              prep.spectator, prep.flip, prep.e01, prep.e10)


def thermometry_block(ctx, p: dict) -> tuple:
    """``(label, z)``: the deviance residuals of ``ctx.camp.thermometry`` (one row per
    point, bright and dark) at the parameter set ``p`` of the gate model ``ctx.gate``."""
    th = ctx.camp.thermometry
    pb = thermometry_probabilities(ctx.gate, p, th["wait_s"].to_numpy(float),
                                   th["sideband"].to_numpy())
    n = th["n_bright"].to_numpy(float)
    N = th["shots"].to_numpy(float)
    z = deviance_residuals(np.stack([n, N - n], axis=1), N, np.stack([pb, 1 - pb], axis=1))
    return {"kind": "thermometry", "observable": "thermometry"}, z.ravel()


def recorded_motion(prob, base) -> dict | None:
    """The motional state the thermometry records on its own, beside the lab's stated one:
    ``nbar`` (quanta) and ``heating_q_per_ms``, each ``{"recorded", "error", "stated"}``
    (None without thermometry or gates, or before the baseline is fitted).  The offsets
    :data:`~dpdfit.analyses.diagnosis.model.recorded_motion.MOTION_NUISANCES` are fitted
    to the thermometry block alone, the other parameters at the baseline's (Gauss-Newton
    errors).  Reported, not fitted with the
    gates: the stated state stays the baseline's, so that a heating the recording shows is
    named as the catalog's effect, with the gates' evidence."""
    gate = getattr(prob, "gate", None)
    if gate is None or getattr(prob.camp, "thermometry", None) is None or base is None:
        return None
    stated = {"nbar": float(gate.nominal["nbar"]),
              "heating_q_per_ms": float(gate.nominal["ndot"]) / 1e3}
    p0 = dict(base.all_params)

    def z(x):
        return thermometry_block(prob, {**p0, "thermo_dnbar": x[0], "thermo_dndot": x[1]})[1]
    lo = [-stated["nbar"], -stated["heating_q_per_ms"]]
    res = least_squares(z, [0.0, 0.0], bounds=(lo, [5.0, 5.0]), x_scale=[0.1, 0.05])
    try:
        err = np.sqrt(np.diag(np.linalg.inv(res.jac.T @ res.jac)))
    except np.linalg.LinAlgError:
        err = np.full(2, np.nan)
    return {name: {"recorded": stated[name] + float(res.x[i]), "error": float(err[i]),
                   "stated": stated[name]}
            for i, name in enumerate(("nbar", "heating_q_per_ms"))}
