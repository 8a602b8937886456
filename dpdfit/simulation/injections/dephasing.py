"""How the simulator injects ``dephasing``: extra qubit dephasing, in every form.

During the gate, the engine's Lindblad ``Z`` noise: a constant rate for ``beta = 1``
(as the lab's own ``T2``) and otherwise the time-local rate ``dG/dt`` of the same
``G(t)`` (:mod:`dpdfit.models.gate_sim.dephasing`; exact for Gaussian noise on a free
qubit, so ``beta = 2`` is quasi-static noise, a random frequency offset per shot); on
the final coherences, ``exp(-G(t_gate))`` of each ion's coherence and
``exp(-2 (1 + f_cm) G)`` of ``|00><11|``, applied to the engine's states before the
analysis pulse.  ``t_ref`` is the campaign's median nominal gate time; the truth is
restated at the diagnosis's ``t_ref`` (:meth:`DephasingInjection.truth`).

The harness draws slow noise as compressed exponentials, ``1.5 <= beta <= 2.5``
(quasi-static noise is 2), and every form but the catalog's at 20-100 /s instead of
30-150 /s: a common part, slow noise late in the gate or a decay of the final
coherences costs the parity contrast up to about twice what the same independent rate
during the gate costs.
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.effects.dephasing import EFFECT
from dpdfit.models.gate_sim.dephasing import accumulated_dephasing

from .base import Injection

__all__ = ["DephasingInjection", "INJECTION"]

# harness strengths of the forms: the catalog's rate; a lower one where the same rate
# costs the parity contrast more (a common part: |00><11| decays by 2 (1 + f_cm) G; slow
# noise late in the gate; a decay of the final coherences); a common-mode fraction
# clearly inside (0, 1); slow noise as a compressed exponential
_RATE, _RATE_SHARED = (30.0, 150.0, False), (20.0, 100.0, False)
_FCM, _BETA = (0.2, 0.8, False), (1.5, 2.5, False)


class DephasingInjection(Injection):
    """Extra dephasing in the gate engine (during the gate) or of the final state's
    coherences, independent on each ion and/or common to both."""

    effect = EFFECT
    harness = {"rate": (30.0, 150.0, False), "f_cm": (0.0, 1.0, False)}
    harness_forms = {"independent": {"rate": _RATE},
                     "common": {"rate": _RATE_SHARED},
                     "mixed": {"rate": _RATE_SHARED, "f_cm": _FCM},
                     "stretched": {"rate": _RATE_SHARED, "f_cm": (0.0, 1.0, False),
                                   "beta": _BETA},
                     "coherence": {"rate": _RATE_SHARED},
                     "coherence_mixed": {"rate": _RATE_SHARED, "f_cm": _FCM},
                     "coherence_stretched": {"rate": _RATE_SHARED, "f_cm": (0.0, 1.0, False),
                                             "beta": _BETA}}
    inject_refs = ("t_ref",)

    def inject_engine(self, v, kw, A):
        # during the gate: the engine's Lindblad noise (on the final coherences instead:
        # inject_coherence)
        if v.get("during", 1.0) < 0.5:
            return kw
        rate, f, beta = v.get("rate", 0.0), v.get("f_cm", 0.0), v.get("beta", 1.0)
        kw = dict(kw)
        if beta != 1.0:
            # slow noise: a time-local rate accumulating G(t) (module doc)
            kw["dephasing_profile"] = ((1 - f) * rate, f * rate, beta, v["t_ref"])
            return kw
        if (1 - f) * rate > 0:
            kw["T2"] = 1.0 / (1.0 / kw["T2"] + (1 - f) * rate)
        if f * rate > 0:
            kw["T2_corr"] = 1.0 / (1.0 / kw.get("T2_corr", np.inf) + f * rate)
        return kw

    def inject_coherence(self, v, t_gate):
        if v.get("during", 1.0) >= 0.5:
            return None
        G = float(accumulated_dephasing(v.get("rate", 0.0), v.get("beta", 1.0), v["t_ref"],
                                        t_gate))
        return np.exp(-G), np.exp(-2 * (1 + v.get("f_cm", 0.0)) * G)

    def injected(self, v):
        return {"rate": float(v.get("rate", 0.0)), "f_cm": float(v.get("f_cm", 0.0)),
                "beta": float(v.get("beta", 1.0)), "during": float(v.get("during", 1.0))}

    def truth(self, v, sim_truth, ctx=None):
        """The injected sizes at the diagnosis's ``t_ref`` (the median recorded gate
        time): ``G(t)`` is the simulator's, whose ``t_ref`` is the median *nominal* gate
        time, so for ``beta != 1`` the rate at the diagnosis's is
        ``rate (t_ref / t_ref_sim)^(beta - 1)``."""
        v = self.injected(v)
        gate = getattr(ctx, "gate", None) if ctx is not None else None
        settings = (sim_truth.get("gates") or {}).get("settings") or []
        if v["beta"] != 1.0 and gate is not None and settings:
            t_sim = float(np.median([1.0 / s["xi0_true_hz"] for s in settings]))
            v["rate"] *= (gate.t_ref / t_sim) ** (v["beta"] - 1.0)
        p = {self.effect.key(k): x for k, x in v.items()}
        return {k: val for k, (val, _, _) in self.effect.size_values(ctx, p).items()}


INJECTION = DephasingInjection()
