"""``spam_offset``: extra state-preparation error per ion (gate side), added to the
lab's known total and split like it (:mod:`dpdfit.analyses.diagnosis.gate_model`)."""

from __future__ import annotations

from .base import Effect, Param

__all__ = ["SPAM_OFFSET"]

SPAM_OFFSET = Effect(
    "spam_offset", "gates",
    (Param("p_prep", "probability", 0.0, 0.2, 0.001, 0.005),),
    "extra state-preparation error per ion (constant offset)")
