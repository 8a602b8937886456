"""The motional state the sideband thermometry records, beside the lab's stated one.

With ``thermometry.csv`` the recording is data of every hypothesis (the heating effects
predict it through the gate engine's knobs of
:mod:`~dpdfit.analyses.diagnosis.effects.motional_heating`).  The lab's stated initial
mean phonon number and heating rate (``campaign.json`` ``error_model``: ``nbar``,
``heating_quanta_per_s``) stay the baseline's: were the recorded state a free nuisance of
the baseline, a heating the recording shows would be taken up by it and the catalog's
``motional_heating`` never named.  :func:`recorded_motion` reports what the recording
measures on its own (the offsets :data:`MOTION_NUISANCES` fitted to it alone, acting as
:class:`RecordedMotion` does) beside the stated values (the null model's
``recorded_motion``).  Without ``thermometry.csv`` none of this exists.
"""

from __future__ import annotations


import numpy as np
from scipy.optimize import least_squares

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
    """The motional state the thermometry records on its own, beside the lab's stated one:
    ``nbar`` (quanta) and ``heating_q_per_ms``, each ``{"recorded", "error", "stated"}``
    (None without thermometry or gates, or before the baseline is fitted).  The offsets
    :data:`MOTION_NUISANCES` are fitted to the thermometry block alone, the other
    parameters at the baseline's (Gauss-Newton errors).  Reported, not fitted with the
    gates: the stated state stays the baseline's, so that a heating the recording shows is
    named as the catalog's effect, with the gates' evidence."""
    gate = getattr(prob, "gate", None)
    if gate is None or getattr(prob.camp, "thermometry", None) is None or base is None:
        return None
    # here, not at the top: the block reads the gate model's effect terms, which import
    # this module
    from dpdfit.analyses.diagnosis.model.thermometry_block import thermometry_block
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
