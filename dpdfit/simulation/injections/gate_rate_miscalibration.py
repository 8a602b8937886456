"""How the simulator injects ``gate_rate_miscalibration``: a power error at gate time.

The engine's power error at each setting is ``eps + slope (A - A_ref)`` with ``A_ref``
the mean amplitude of the campaign's own gate settings (the diagnosis's definition; a
further recording at a new amplitude moves the diagnosis's ``A_ref`` but not the lab's
physics, so the truth is restated at the diagnosis's ``A_ref``).  Harness slope:
0.5-1.5 dB per unit A, i.e. 0.1-0.3 dB across the harness's gate amplitudes 0.4-0.8
(e.g. a power calibration made at one amplitude of a modulator whose efficiency
drifted).
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.effects.gate_rate_miscalibration import EFFECT

from .base import Injection

__all__ = ["GateRateMiscalibrationInjection", "INJECTION"]


class GateRateMiscalibrationInjection(Injection):
    """The gate engine's optical power off by ``eps + slope (A - A_ref)`` dB."""

    effect = EFFECT
    harness = {"eps": (0.15, 0.4, True)}
    harness_forms = {"linear": {"eps": (0.15, 0.4, True), "slope": (0.5, 1.5, True)}}
    inject_refs = ("A_ref",)

    def inject_engine(self, v, kw, A):
        eps = v.get("eps", 0.0)
        if v.get("slope", 0.0):
            eps = eps + v["slope"] * (A - v["A_ref"])
        return {**kw, "power_error_db": kw.get("power_error_db", 0.0) + eps}

    def truth(self, v, sim_truth, ctx=None):
        """The injected sizes at the diagnosis's ``A_ref`` (the simulator's is the mean of
        the campaign's own gate amplitudes; module doc)."""
        v = self.injected(v)
        amps = (sim_truth.get("config") or {}).get("gate_amplitudes")
        gate = getattr(ctx, "gate", None) if ctx is not None else None
        if v.get("slope") and gate is not None and amps:
            v["eps"] += v["slope"] * (gate.A_ref - float(np.mean(amps)))
        p = {self.effect.key(k): x for k, x in v.items()}
        return {k: val for k, (val, _, _) in self.effect.size_values(ctx, p).items()}


INJECTION = GateRateMiscalibrationInjection()
