"""The simulator's injections of the diagnosis's effects, one module per effect.

Each module defines one :class:`~dpdfit.simulation.injections.base.Injection`: the effect it injects
(:mod:`dpdfit.analyses.diagnosis.effects`, what the diagnosis fits), how the campaign
simulator puts it into a simulated campaign (``inject_*`` hooks), the strengths the
harness draws per form and the truth it compares.  :mod:`.registry` lists them
(``INJECTIONS``) by the name of their effect.
"""

from .base import Injection
from .draws import draw_uniform
from .registry import INJECTIONS, get, register, unregister

__all__ = ["Injection", "draw_uniform", "INJECTIONS", "register", "unregister", "get"]
