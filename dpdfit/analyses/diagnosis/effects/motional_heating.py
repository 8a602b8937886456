"""``motional_heating``: the gate mode heats faster than the lab's model (gate side).

Catalog form ("during"): extra quanta per ms during the gate (``ndot``).

Variant "initial": heating during the gate plus extra initial phonons
``dnbar`` (a hot tail of the distribution).
"""

from __future__ import annotations

from .base import Effect, Param

__all__ = ["MOTIONAL_HEATING", "MOTIONAL_HEATING_INITIAL"]

MOTIONAL_HEATING = Effect(
    "motional_heating", "gates",
    (Param("ndot", "quanta/ms", 0.0, 5.0, 0.01, 0.05),),
    "gate mode heating faster than the lab's model (extra quanta per ms during the gate)",
    form="during")

MOTIONAL_HEATING_INITIAL = Effect(
    "motional_heating", "gates",
    (Param("ndot", "quanta/ms", 0.0, 5.0, 0.01, 0.05),
     Param("dnbar", "quanta", 0.0, 5.0, 0.01, 0.1)),
    "gate mode hotter than the lab's model both during the gate (ndot) and at its start "
    "(dnbar extra initial phonons, e.g. a hot tail of the distribution)",
    form="initial", variant=True)
