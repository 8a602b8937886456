"""An effect registered for the length of a test, and removed again whatever happens."""

import contextlib

from dpdfit.analyses.diagnosis.effects import EFFECTS, register, unregister


@contextlib.contextmanager
def registered_effect(effect):
    """Register ``effect`` at run time (as a lab's own effect is); unregister it after."""
    register(effect)
    try:
        yield effect
    finally:
        unregister(effect.name)
    assert effect.name not in EFFECTS
