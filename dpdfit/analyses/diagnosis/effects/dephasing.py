"""``dephasing``: extra qubit dephasing beyond the lab's error model (gate side).

Family: each ion's coherence decays by an extra ``exp(-G(t))`` with
``G(t) = rate t_ref (t/t_ref)^beta`` (``beta = 1``: a rate; ``beta != 1``: a
stretched or compressed exponential, e.g. slow noise), a fraction ``f_cm`` of
which is common to both ions (e.g. magnetic-field noise: the Bell state's
coherence then decays by ``2 (1 + f_cm) G``).  ``t_ref`` is the campaign's median
gate time, so ``rate`` is the extra dephasing rate at the gate time.

In the model the engine's linear responses to an independent rate (Lindblad
``Z_j``) and a common one (``Z_1 + Z_2``) are weighted at each observation time
``t`` by the effective rate ``G(t)/t`` (exact for ``beta = 1``; for other
``beta`` it treats the dephasing accumulated by ``t`` as what matters).

Where it acts (``during``): ``1`` -- during the gate, through the engine
(Lindblad ``Z`` noise, which also disturbs the gate's populations); ``0`` -- on
the final state's coherences only (noise too slow to act within the gate's
loops, or between the gate and the analysis pulse: the parity contrast decays,
the populations do not).

In free precession (``ramsey.csv``, :meth:`Dephasing.free_dephasing`) each ion dephases
by the same ``G(t)`` over the wait, the echo removing slow noise (``beta > 1``) and not
white (:mod:`dpdfit.models.ramsey` states the assumption): the recording measures every
form, the white independent one as a coherence time shorter than the lab's stated ``T2``.

Forms: ``independent`` (catalog: ``f_cm = 0``, ``beta = 1``, during the gate),
``common`` (``f_cm = 1``), ``mixed`` (``f_cm`` free), ``stretched`` (``f_cm`` and
``beta`` free), and ``coherence``, ``coherence_mixed``, ``coherence_stretched``:
the same on the final state's coherences.  Priors: flat, 0 <= rate <= 5000 /s, 0 <= f_cm <= 1, 0.3 <= beta <= 3.
Sizes: ``rate_per_s`` (the harness's main quantity), ``T2_ms`` (coherence time
of the extra decay, ``exp(-(t/T2)^beta)``), ``f_cm``, ``beta``.
"""

from __future__ import annotations

import numpy as np

from dpdfit.models.ramsey import free_dephasing

from .base import Effect, Form, Knob, Param

__all__ = ["Dephasing", "EFFECT", "INDEPENDENT", "COMMON"]


def _independent(nominal, step):
    return {**nominal, "T2": 1.0 / (1.0 / nominal["T2"] + step)}


def _common(nominal, step):
    c = 1.0 / nominal.get("T2_corr", np.inf)
    return {**nominal, "T2_corr": 1.0 / (c + step)}


INDEPENDENT = Knob("dephasing.independent", 100.0, "1/s", _independent, nonlinear=True)
COMMON = Knob("dephasing.common", 100.0, "1/s", _common, nonlinear=True)


def _profile_forms(name: str, during: float, what: str, where: str) -> tuple:
    """The rate alone, with a common-mode fraction, and with a time profile too, each
    started from the one before: during the gate (``during`` 1, ``name`` "" gives
    independent/mixed/stretched) or on the final coherences (0)."""
    base = name or "independent"
    mixed = f"{name}_mixed" if name else "mixed"
    return (Form(base, ("rate",), {"f_cm": 0.0, "beta": 1.0, "during": during}, what),
            Form(mixed, ("rate", "f_cm"), {"beta": 1.0, "during": during},
                 f"{where}a common-mode fraction", starts_from=base,
                 extra_starts=({"f_cm": 0.5},)),
            Form(f"{name}_stretched" if name else "stretched", ("rate", "f_cm", "beta"),
                 {"during": during}, f"{where}a common-mode fraction and a time profile",
                 starts_from=mixed, extra_starts=({"beta": 1.5}, {"beta": 0.7})))


# the forms during the gate (the common-mode form goes after the first)
_DURING = _profile_forms("", 1.0, "independent on each ion, a rate", "")


class Dephasing(Effect):
    """Extra qubit dephasing (rate in 1/s at the median gate time), independent on
    each ion and/or common to both, during the gate or on the final state's
    coherences."""

    name = "dephasing"
    side = "gates"
    meaning = "extra qubit dephasing (independent on each ion and/or common to both)"
    params = (Param("rate", "1/s", 0.0, 5000.0, 10.0, 20.0, "extra dephasing rate at t_ref"),
              Param("f_cm", "1", 0.0, 1.0, 0.3, 0.1, "fraction common to both ions"),
              Param("beta", "1", 0.3, 3.0, 1.0, 0.1, "time-profile exponent"),
              Param("during", "1", 0.0, 1.0, 1.0, 1.0,
                    "1: during the gate; 0: on the final state's coherences"))
    forms = (_DURING[0],
             Form("common", ("rate",), {"f_cm": 1.0, "beta": 1.0, "during": 1.0},
                  "common to both ions"),
             *_DURING[1:],
             *_profile_forms("coherence", 0.0, "on the final state's coherences",
                             "on the coherences, "))
    main = "rate_per_s"

    def knobs(self):
        return (INDEPENDENT, COMMON)

    def knob_coefficients(self, gm, v, t):
        if v.get("during", 1.0) < 0.5:
            return {}
        t = np.asarray(t, dtype=float)
        g = v.get("rate", 0.0) * (np.maximum(t, 1e-300) / gm.t_ref) ** (v.get("beta", 1.0) - 1)
        f = v.get("f_cm", 0.0)
        return {INDEPENDENT.key: (1 - f) * g, COMMON.key: f * g}

    def coherence(self, gm, v, t):
        if v.get("during", 1.0) >= 0.5:
            return None
        # accumulated dephasing G(t) = rate t_ref (t/t_ref)^beta of each ion; |00><11| of
        # two ions decays by 2 (1 + f_cm) G
        t = np.asarray(t, dtype=float)
        G = v.get("rate", 0.0) * gm.t_ref * (np.maximum(t, 0.0) / gm.t_ref) ** v.get("beta", 1.0)
        return np.exp(-G), np.exp(-2 * (1 + v.get("f_cm", 0.0)) * G)

    def free_dephasing(self, gm, v, t, echo):
        rate, f, beta = v.get("rate", 0.0), v.get("f_cm", 0.0), v.get("beta", 1.0)
        G = free_dephasing(rate, beta, gm.t_ref, t, echo)
        return (1.0 - f) * G, f * G

    def size_values(self, ctx, p):
        v = self.values(p) or {}
        rate, beta = v.get("rate", 0.0), v.get("beta", 1.0)
        t_ref = ctx.gate.t_ref if ctx is not None and getattr(ctx, "gate", None) else 2.5e-4
        # exp(-(t/T2)^beta) = exp(-rate t_ref (t/t_ref)^beta)
        T2 = t_ref * (rate * t_ref) ** (-1.0 / beta) if rate > 0 else float("inf")
        return {"rate_per_s": (rate, "1/s", "extra dephasing rate at the median gate time"),
                "T2_ms": (T2 * 1e3, "ms", "coherence time of the extra dephasing"),
                "f_cm": (v.get("f_cm", 0.0), "1", "fraction common to both ions"),
                "beta": (beta, "1", "time-profile exponent"),
                "during_gate": (v.get("during", 1.0), "1",
                                "1: during the gate, 0: on the final state's coherences")}


EFFECT = Dephasing()
