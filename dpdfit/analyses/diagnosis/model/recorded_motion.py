"""The motional state the sideband thermometry records, beside the lab's stated one.

With ``thermometry.csv`` the recording is data of every hypothesis (the heating effects
predict it through the gate engine's knobs of
:mod:`~dpdfit.analyses.diagnosis.effects.motional_heating`).  The lab's stated initial
mean phonon number and heating rate (``campaign.json`` ``error_model``: ``nbar``,
``heating_quanta_per_s``) stay the baseline's: were the recorded state a free nuisance of
the baseline, a heating the recording shows would be taken up by it and the catalog's
``motional_heating`` never named.
:func:`~dpdfit.analyses.diagnosis.model.thermometry_block.recorded_motion` reports what
the recording measures on its own (the offsets :data:`MOTION_NUISANCES` fitted to it
alone, acting as :class:`RecordedMotion` does) beside the stated values (the null
model's ``recorded_motion``).  Without ``thermometry.csv`` none of this exists.
"""

from __future__ import annotations

from dpdfit.analyses.diagnosis.effects.base import Effect, Param
from dpdfit.analyses.diagnosis.effects.motional_heating import NBAR, NDOT

__all__ = ["MOTION_NUISANCES", "RecordedMotion", "RECORDED_MOTION", "motion_values"]

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

