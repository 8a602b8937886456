"""The simulator's injections, by the name of the effect each injects.

Adding an effect's injection: a module beside this one defining it (:mod:`~dpdfit.simulation.injections.base`),
and one line in ``_CATALOG`` below (or, from outside the package, e.g. a test,
:func:`register`, after registering the effect itself with
:func:`dpdfit.analyses.diagnosis.effects.register`).  The effects themselves, and
their order, are the diagnosis's registry's
(:data:`~dpdfit.analyses.diagnosis.effects.registry.EFFECTS`): an effect without an
injection here is injected by the base class, which changes nothing (:func:`get`).
"""

from __future__ import annotations

from dpdfit.analyses.diagnosis import effects

from . import (am_pm_omitted, aom_memory, dephasing, detector_nonlinearity,
               gate_rate_miscalibration, higher_nbar, higher_order_im, motional_heating,
               spam_offset, stale_calibration)
from .base import Injection

__all__ = ["INJECTIONS", "register", "unregister", "get"]

_CATALOG = (
    am_pm_omitted.INJECTION,
    aom_memory.INJECTION,
    stale_calibration.INJECTION,
    higher_order_im.INJECTION,
    detector_nonlinearity.INJECTION,
    motional_heating.INJECTION,
    dephasing.INJECTION,
    spam_offset.INJECTION,
    gate_rate_miscalibration.INJECTION,
    higher_nbar.INJECTION,
)

#: effect name -> its injection (registered injections included)
INJECTIONS: dict = {i.effect.name: i for i in _CATALOG}


def register(injection: Injection) -> Injection:
    """Add ``injection`` for its effect, which must be registered (an effect's injection
    may be registered once)."""
    if not isinstance(injection, Injection):
        raise TypeError(f"not an Injection: {injection!r}")
    e = injection.effect
    if e is None or effects.EFFECTS.get(e.name) is not e:
        raise ValueError(f"the effect {getattr(e, 'name', None)!r} of this injection is not "
                         "registered (dpdfit.analyses.diagnosis.effects.register it first)")
    if e.name in INJECTIONS and INJECTIONS[e.name] is not injection:
        raise ValueError(f"an injection of {e.name!r} is already registered")
    INJECTIONS[e.name] = injection
    return injection


def unregister(name: str) -> None:
    """Remove the registered injection of the effect ``name`` (the catalog's own stay)."""
    if any(i.effect.name == name for i in _CATALOG):
        raise ValueError(f"the injection of {name!r} belongs to the catalog")
    INJECTIONS.pop(name, None)


def get(name: str) -> Injection:
    """The injection of the effect called ``name``: its registered one, else one that
    changes nothing (KeyError naming the known effects for an unknown name)."""
    effect = effects.get(name)
    injection = INJECTIONS.get(name)
    if injection is not None and injection.effect is effect:
        return injection
    return Injection(effect)
