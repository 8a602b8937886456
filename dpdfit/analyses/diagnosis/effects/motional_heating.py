"""``motional_heating``: the gate mode is hotter than the lab's model (gate side).

Family: extra heating during the gate ``ndot`` (quanta/ms) and extra initial
phonons ``dnbar`` (e.g. a hot tail of the distribution after cooling).
Forms: ``during`` (catalog: ``ndot``), ``initial`` (``dnbar``), ``both``.
Linear engine responses at every setting and scan time.

Priors: flat, 0 <= ndot <= 5 quanta/ms, 0 <= dnbar <= 5.  Sizes:
``heating_q_per_ms`` (the total heating rate, the lab's plus the extra; the
harness's main quantity), ``extra_heating_q_per_ms``, ``mean_nbar`` (initial).
"""

from __future__ import annotations

import dataclasses

from .base import Effect, Form, Knob, Param

__all__ = ["MotionalHeating", "EFFECT", "NDOT", "NBAR", "replacing_recorded_motion"]

#: with ``thermometry.csv``, the baseline's nuisance of the recorded motional state each
#: heating parameter replaces (:mod:`~dpdfit.analyses.diagnosis.model.recorded_motion`)
_RECORDED = {"ndot": "thermo_dndot", "dnbar": "thermo_dnbar"}


def replacing_recorded_motion(forms: tuple, ctx) -> tuple:
    """A heating effect's ``forms``, each replacing the recorded-motion nuisance of every
    parameter it frees, when the problem ``ctx`` fits those nuisances (the diagnosis does
    not: the lab's stated motional state stays the baseline's, and the heating the
    thermometry records is the catalog's effect; unchanged then)."""
    if not any(k in (getattr(ctx, "prior", None) or {}) for k in _RECORDED.values()):
        return forms
    return tuple(dataclasses.replace(f, replaces=tuple(dict.fromkeys(
        f.replaces + tuple(_RECORDED[k] for k in f.free if k in _RECORDED)))) for f in forms)


def _ndot(nominal, step):
    return {**nominal, "ndot": nominal["ndot"] + step * 1e3}


def _nbar(nominal, step):
    return {**nominal, "nbar": nominal["nbar"] + step}


NDOT = Knob("heating.ndot", 0.1, "quanta/ms", _ndot, nonlinear=True)
#: shared with :mod:`~dpdfit.analyses.diagnosis.effects.higher_nbar`
NBAR = Knob("initial.nbar", 0.2, "quanta", _nbar)


class MotionalHeating(Effect):
    """A hotter gate mode than the lab's model: heating during the gate
    (``ndot``, quanta/ms), extra initial phonons (``dnbar``), or both."""

    name = "motional_heating"
    side = "gates"
    meaning = "the gate mode is hotter than the lab's model (heating during the gate, "\
              "extra initial phonons)"
    params = (Param("ndot", "quanta/ms", 0.0, 5.0, 0.01, 0.05, "extra heating rate"),
              Param("dnbar", "quanta", 0.0, 5.0, 0.01, 0.1, "extra initial mean phonons"))
    forms = (Form("during", ("ndot",), {"dnbar": 0.0}, "heating during the gate"),
             Form("initial", ("dnbar",), {"ndot": 0.0}, "extra initial phonons"),
             Form("both", ("ndot", "dnbar"), {}, "both", starts_from="during"))
    main = "heating_q_per_ms"

    def forms_for(self, ctx=None) -> tuple:
        return replacing_recorded_motion(super().forms_for(ctx), ctx)

    def knobs(self):
        return (NDOT, NBAR)

    def knob_coefficients(self, gm, v, t):
        return {NDOT.key: v.get("ndot", 0.0), NBAR.key: v.get("dnbar", 0.0)}

    def _nominal(self, ctx):
        gate = getattr(ctx, "gate", None)
        return (gate.nominal["ndot"] / 1e3, gate.nominal["nbar"]) if gate else (0.0, 0.0)

    def size_values(self, ctx, p):
        v = self.values(p) or {}
        ndot0, nbar0 = self._nominal(ctx)
        return {"heating_q_per_ms": (ndot0 + v.get("ndot", 0.0), "quanta/ms",
                                     "heating rate of the gate mode (lab's + extra)"),
                "extra_heating_q_per_ms": (v.get("ndot", 0.0), "quanta/ms",
                                           "beyond the lab's model"),
                "mean_nbar": (nbar0 + v.get("dnbar", 0.0), "quanta",
                              "initial mean phonon number")}


EFFECT = MotionalHeating()
