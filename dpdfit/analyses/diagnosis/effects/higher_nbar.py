"""``higher_nbar``: a higher initial mean phonon number than the lab's model (gate
side; not in the default ranking: :mod:`~dpdfit.analyses.diagnosis.effects.motional_heating`'s ``initial`` form covers it).

Prior: flat, 0 <= dnbar <= 5.  Size: ``mean_nbar``.
"""

from __future__ import annotations

from .base import Effect, Param
from .motional_heating import NBAR, replacing_recorded_motion

__all__ = ["HigherNbar", "EFFECT"]


class HigherNbar(Effect):
    """A higher initial mean phonon number of the gate mode (``dnbar``, quanta);
    not among the default effects."""

    name = "higher_nbar"
    side = "gates"
    meaning = "higher initial mean phonon number"
    params = (Param("dnbar", "quanta", 0.0, 5.0, 0.05, 0.1, "extra initial mean phonons"),)
    default = False
    main = "mean_nbar"

    def forms_for(self, ctx=None) -> tuple:
        return replacing_recorded_motion(super().forms_for(ctx), ctx)

    def knobs(self):
        return (NBAR,)

    def knob_coefficients(self, gm, v, t):
        return {NBAR.key: v.get("dnbar", 0.0)}

    def size_values(self, ctx, p):
        gate = getattr(ctx, "gate", None)
        nbar0 = gate.nominal["nbar"] if gate else 0.0
        return {"mean_nbar": (nbar0 + (self.values(p) or {}).get("dnbar", 0.0), "quanta",
                              "initial mean phonon number")}


EFFECT = HigherNbar()
