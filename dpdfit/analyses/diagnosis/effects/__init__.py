"""The diagnosis's catalog of candidate effects, one module per effect.

Each module defines one :class:`~dpdfit.analyses.diagnosis.effects.base.Effect`: its family of parameters and
forms, what it does to the optical field or to the gates, how its size is stated
in a laboratory's terms.  :mod:`~dpdfit.analyses.diagnosis.effects.registry` lists them (``EFFECTS``) and derives
every list of effects the rest of the package uses.  How the simulator injects
each one lives with the simulator (:mod:`dpdfit.simulation.injections`).
"""

from .base import SIDES, Effect, Form, Knob, Param, Prep, Size
from .registry import (EFFECTS, default_effects, effect_of_key, get, register, side_effects,
                       unregister)

__all__ = ["Param", "Form", "Knob", "Prep", "Size", "Effect", "SIDES", "EFFECTS", "register",
           "unregister", "get", "effect_of_key", "default_effects", "side_effects"]
