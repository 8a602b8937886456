"""How the simulator injects ``higher_nbar``: extra initial phonons of the gate mode."""

from __future__ import annotations

from dpdfit.analyses.diagnosis.effects.higher_nbar import EFFECT

from .base import Injection

__all__ = ["HigherNbarInjection", "INJECTION"]


class HigherNbarInjection(Injection):
    """The gate engine's initial mean phonon number raised by ``dnbar``."""

    effect = EFFECT
    harness = {"dnbar": (0.1, 0.5, False)}

    def inject_engine(self, v, kw, A):
        return {**kw, "nbar": kw["nbar"] + v.get("dnbar", 0.0)}


INJECTION = HigherNbarInjection()
