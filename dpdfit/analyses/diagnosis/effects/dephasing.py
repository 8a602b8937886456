"""``dephasing``: extra qubit dephasing beyond the lab's error model (gate side).

Catalog form ("independent"): an extra rate ``gamma`` (1/s), independent on
each ion; the loss grows with the gate time.

Variant "correlated": dephasing common to both ions (rate ``gamma_c`` of
``Z1 + Z2``, e.g. magnetic-field noise).
"""

from __future__ import annotations

from .base import Effect, Param

__all__ = ["DEPHASING", "DEPHASING_CORRELATED"]

DEPHASING = Effect(
    "dephasing", "gates",
    (Param("gamma", "1/s", 0.0, 2000.0, 10.0, 20.0),),
    "extra qubit dephasing, independent on each ion (loss grows with gate time)",
    form="independent")

DEPHASING_CORRELATED = Effect(
    "dephasing", "gates", (Param("gamma_c", "1/s", 0.0, 2000.0, 10.0, 20.0),),
    "extra dephasing common to both ions (e.g. magnetic-field noise): rate gamma_c of "
    "Z1 + Z2",
    form="correlated", variant=True)
