"""An effect registered for the length of a test, and removed again whatever happens."""

import contextlib

from dpdfit.analyses.diagnosis.effects import EFFECTS, register, unregister
from dpdfit.simulation import injections


@contextlib.contextmanager
def registered_effect(effect, injection=None):
    """Register ``effect`` (and its ``injection`` into the simulator, if given) at run time
    (as a lab's own effect is); unregister both after."""
    register(effect)
    try:
        if injection is not None:
            injections.register(injection)
        yield effect
    finally:
        injections.unregister(effect.name)
        unregister(effect.name)
    assert effect.name not in EFFECTS and effect.name not in injections.INJECTIONS
