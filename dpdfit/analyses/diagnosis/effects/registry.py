"""The catalog of candidate effects: every effect module's :class:`~dpdfit.analyses.diagnosis.effects.base.Effect`, by name.

Adding an effect: a module beside this one defining it (its parameters, forms
and behaviour, :mod:`~dpdfit.analyses.diagnosis.effects.base`), and one line in ``_CATALOG`` below (or, from
outside the package, e.g. a test, :func:`register`).  Everything else that
lists effects -- the default effects of ``diagnose``, the gate-side effects of
the null model, the effects the simulator takes, the catalog table of the
documentation -- is derived from the registry.  The order is the order of the
fits and of the reports.  An effect's injection into the simulator is
registered on the simulator's side (:mod:`dpdfit.simulation.injections.registry`).
"""

from __future__ import annotations

from . import (am_pm_omitted, aom_memory, dephasing, detector_nonlinearity,
               gate_rate_miscalibration, higher_nbar, higher_order_im, motional_heating,
               spam_offset, stale_calibration)
from .base import SIDES, Effect

__all__ = ["EFFECTS", "register", "unregister", "get", "effect_of_key", "default_effects",
           "side_effects"]

_CATALOG = (
    am_pm_omitted.EFFECT,
    aom_memory.EFFECT,
    stale_calibration.EFFECT,
    higher_order_im.EFFECT,
    detector_nonlinearity.EFFECT,
    motional_heating.EFFECT,
    dephasing.EFFECT,
    spam_offset.EFFECT,
    gate_rate_miscalibration.EFFECT,
    higher_nbar.EFFECT,
)

#: catalog name -> effect (registered effects included)
EFFECTS: dict = {e.name: e for e in _CATALOG}


def register(effect: Effect) -> Effect:
    """Add ``effect`` to the catalog (a name may be registered once)."""
    if not isinstance(effect, Effect):
        raise TypeError(f"not an Effect: {effect!r}")
    if not effect.name or "." in effect.name or "+" in effect.name:
        raise ValueError(f"an effect's name must be non-empty without '.' or '+': "
                         f"{effect.name!r}")
    if effect.side not in SIDES:
        raise ValueError(f"effect {effect.name}: side must be one of {SIDES}")
    if effect.name in EFFECTS and EFFECTS[effect.name] is not effect:
        raise ValueError(f"an effect named {effect.name!r} is already registered")
    EFFECTS[effect.name] = effect
    return effect


def unregister(name: str) -> None:
    """Remove a registered effect (the catalog's own stay)."""
    if any(e.name == name for e in _CATALOG):
        raise ValueError(f"{name!r} belongs to the catalog")
    EFFECTS.pop(name, None)


def get(name: str) -> Effect:
    """The effect called ``name`` (KeyError naming the known ones otherwise)."""
    try:
        return EFFECTS[name]
    except KeyError:
        raise KeyError(f"unknown effect {name!r}; known: {', '.join(EFFECTS)}") from None


def effect_of_key(key: str) -> Effect | None:
    """The effect a fit parameter ``"<effect>.<param>"`` belongs to (None: a nuisance)."""
    name, dot, _ = key.partition(".")
    return EFFECTS.get(name) if dot else None


def default_effects() -> tuple:
    """Names of the effects ``diagnose`` considers by default (registry order)."""
    return tuple(e.name for e in EFFECTS.values() if e.default)


def side_effects(side: str, names=None) -> tuple:
    """Names of the (default, or given) effects acting on ``side``."""
    names = default_effects() if names is None else names
    return tuple(n for n in names if EFFECTS[n].side == side)
