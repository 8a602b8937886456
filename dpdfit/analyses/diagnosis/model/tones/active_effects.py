"""The tone-side effects present in a parameter set, in the order their hooks apply."""

from __future__ import annotations

from dpdfit.analyses.diagnosis.effects.registry import EFFECTS

__all__ = ["ActiveEffects"]


class ActiveEffects:
    """The effects present in a parameter set, with their values, grouped by hook."""

    def __init__(self, tm, p: dict):
        self.items = []
        for e in EFFECTS.values():
            if e.side != "tones":
                continue
            v = e.values(p)
            if v is not None:
                self.items.append((e, v))
        self.items.sort(key=lambda ev: ev[0].stage)
        self.tm = tm

    def filters(self, f):
        """The present effects' linear filters ``H(f)`` of the complex drive envelope
        at the frequencies ``f`` (Hz), in the order they apply."""
        out = [e.drive_filter(self.tm, v, f) for e, v in self.items]
        return [h for h in out if h is not None]

    def memories(self, f):
        """The present effects' power memories ``(gain, H(f))`` at the frequencies
        ``f`` (Hz): the field is multiplied by ``1 + gain s(t)``, ``s`` the drive power
        through ``H``."""
        out = [e.power_memory(self.tm, v, f) for e, v in self.items]
        return [m for m in out if m is not None]
