"""How the simulator injects ``spam_offset``: extra preparation errors in the gate engine
(its ``p_prep`` is a spectator probability, ``p_flip`` a flip)."""

from __future__ import annotations

from dpdfit.analyses.diagnosis.effects.spam_offset import EFFECT

from .base import Injection

__all__ = ["SpamOffsetInjection", "INJECTION"]


class SpamOffsetInjection(Injection):
    """Extra spectators and flips per ion in the gate engine."""

    effect = EFFECT
    harness = {"p_extra": (0.005, 0.02, False)}
    # the split form with a flip share the lab's (spectator-only) split cannot take
    harness_forms = {"split": {"p_spec": (0.002, 0.01, False), "p_flip": (0.004, 0.012, False)}}

    def inject_engine(self, v, kw, A):
        # the simulator's p_prep is a spectator probability, p_flip a flip
        x = v.get("p_extra", 0.0)
        return {**kw, "p_prep": kw["p_prep"] + x + v.get("p_spec", 0.0),
                "p_flip": kw.get("p_flip", 0.0) + v.get("p_flip", 0.0)}

    def truth(self, v, sim_truth, ctx=None):
        return {"extra_preparation": v.get("p_extra", 0.0) + v.get("p_spec", 0.0)
                + v.get("p_flip", 0.0)}


INJECTION = SpamOffsetInjection()
