"""What the sideband thermometry measures replaces the lab's stated motional state.

With ``thermometry.csv`` the lab's stated initial mean phonon number and heating rate
(``campaign.json`` ``error_model``: ``nbar``, ``heating_quanta_per_s``) are not taken on
trust: the baseline has two nuisances, :data:`MOTION_NUISANCES` (``thermo_dnbar``,
quanta, and ``thermo_dndot``, quanta/ms: the recorded state's offsets from the stated
one; flat priors), constrained by the recording and acting on the gates exactly as the
heating effects do (through the gate engine's knobs of
:mod:`~dpdfit.analyses.diagnosis.effects.motional_heating`, :class:`RecordedMotion`).
The heating effects' parameters then take their place
(:func:`~dpdfit.analyses.diagnosis.effects.motional_heating.replacing_recorded_motion`: a
form of ``motional_heating`` or ``higher_nbar`` replaces the nuisance of each parameter it
frees), so an effect describes only what the
baseline's recorded state does not.  :func:`recorded_motion` reports the recorded values
with their errors beside the stated ones (the null model's ``recorded_motion``).
Without ``thermometry.csv`` none of this exists and the diagnosis is as before.
"""

from __future__ import annotations

import dataclasses

from dpdfit.analyses.diagnosis.effects.base import Effect, Param
from dpdfit.analyses.diagnosis.effects.motional_heating import NBAR, NDOT

__all__ = ["MOTION_NUISANCES", "RecordedMotion", "RECORDED_MOTION", "motion_values",
           "recorded_motion"]

#: the baseline's nuisances of the recorded motional state: name -> (unit, meaning)
MOTION_NUISANCES = {
    "thermo_dnbar": ("quanta", "initial mean phonon number recorded by the thermometry, "
                               "minus the lab's stated one (flat prior)"),
    "thermo_dndot": ("quanta/ms", "heating rate recorded by the thermometry, minus the "
                                  "lab's stated one (flat prior)"),
}


class RecordedMotion(Effect):
    """The baseline's recorded motional state as the gate model sees it: the offsets
    ``dnbar``, ``dndot`` on the knobs the heating effects move (not a catalog effect:
    never ranked, only the nuisances' action)."""

    name = "recorded_motion"
    side = "gates"
    params = (Param("dnbar", "quanta", -10.0, 5.0, 0.0, 0.1),
              Param("dndot", "quanta/ms", -10.0, 5.0, 0.0, 0.05))
    default = False

    def knobs(self):
        return (NDOT, NBAR)

    def knob_coefficients(self, gm, v, t):
        return {NDOT.key: v.get("dndot", 0.0), NBAR.key: v.get("dnbar", 0.0)}


RECORDED_MOTION = RecordedMotion()


def motion_values(p: dict) -> dict | None:
    """``{"dnbar", "dndot"}`` of the nuisances in the parameter set ``p`` (None when
    neither is there: a campaign without thermometry)."""
    if "thermo_dnbar" not in p and "thermo_dndot" not in p:
        return None
    return {"dnbar": float(p.get("thermo_dnbar", 0.0)),
            "dndot": float(p.get("thermo_dndot", 0.0))}


def recorded_motion(prob, base) -> dict | None:
    """The motional state the baseline fit ``base`` recorded, beside the lab's stated one:
    ``nbar`` (quanta) and ``heating_q_per_ms``, each ``{"recorded", "error", "stated"}``
    (None without thermometry or gates)."""
    gate = getattr(prob, "gate", None)
    if gate is None or "thermo_dndot" not in prob.prior or base is None:
        return None
    stated = {"nbar": float(gate.nominal["nbar"]),
              "heating_q_per_ms": float(gate.nominal["ndot"]) / 1e3}
    out = {}
    for name, key in (("nbar", "thermo_dnbar"), ("heating_q_per_ms", "thermo_dndot")):
        err = float("nan")
        if key in base.parameters.names:
            err = float(base.parameters[key].error)
        out[name] = {"recorded": stated[name] + float(base.nuisances.get(key, 0.0)),
                     "error": err, "stated": stated[name]}
    return out
