"""How the simulator injects ``motional_heating``: the gate engine's heating rate and
initial phonons raised by ``ndot`` and ``dnbar``."""

from __future__ import annotations

from dpdfit.analyses.diagnosis.effects.motional_heating import EFFECT

from .base import Injection

__all__ = ["MotionalHeatingInjection", "INJECTION"]


class MotionalHeatingInjection(Injection):
    """A hotter gate mode in the gate engine (heating during the gate, extra initial
    phonons)."""

    effect = EFFECT
    harness = {"ndot": (0.05, 0.2, False)}
    # extra initial phonons as higher_nbar's harness draws them
    harness_forms = {"initial": {"dnbar": (0.1, 0.5, False)},
                     "both": {"ndot": (0.05, 0.2, False), "dnbar": (0.1, 0.5, False)}}
    main_forms = {"initial": "mean_nbar"}

    def inject_engine(self, v, kw, A):
        return {**kw, "ndot": kw["ndot"] + v.get("ndot", 0.0) * 1e3,
                "nbar": kw["nbar"] + v.get("dnbar", 0.0)}


INJECTION = MotionalHeatingInjection()
