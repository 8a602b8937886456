"""``spam_offset``: state-preparation errors beyond the lab's model (gate side).

A preparation error is of two kinds: an ion left in a level outside the gate
(a *spectator*: not driven, reads bright) or prepared in the other qubit state
(a *flip*: driven by the gate).  The lab's known total splits between them by
the baseline's nuisance ``prep_split``; the detection errors ``e01``, ``e10``
are nuisances of their own (:mod:`dpdfit.analyses.diagnosis.model.gates.gate_model`), so
preparation is told apart from detection.

Forms: ``total`` (catalog: an extra error per ion ``p_extra``, split like the
lab's), ``split`` (extra spectator ``p_spec`` and extra flip ``p_flip`` free).
Priors: flat in [0, 0.2].  Sizes: the preparation errors per ion
(``spectator``, ``flip``, ``preparation_total``; the lab's plus the extra) and
the detection errors ``e01``, ``e10``, all with errors that include the
nuisances' uncertainty; ``extra_preparation`` is the harness's main quantity.
"""

from __future__ import annotations

import dataclasses

from .base import Effect, Form, Param

__all__ = ["SpamOffset", "EFFECT"]


class SpamOffset(Effect):
    """State-preparation errors per ion beyond the lab's model: a total split
    like the lab's (``total``) or a spectator level and a flip apart (``split``)."""

    name = "spam_offset"
    side = "gates"
    meaning = "state-preparation errors beyond the lab's model (a level outside the gate, "\
              "a flip)"
    params = (Param("p_extra", "probability", 0.0, 0.2, 0.001, 0.005,
                    "extra preparation error per ion, split like the lab's"),
              Param("p_spec", "probability", 0.0, 0.2, 0.001, 0.005, "extra spectator per ion"),
              Param("p_flip", "probability", 0.0, 0.2, 0.001, 0.005, "extra flip per ion"))
    forms = (Form("total", ("p_extra",), {"p_spec": 0.0, "p_flip": 0.0},
                  "extra error split like the lab's"),
             Form("split", ("p_spec", "p_flip"), {"p_extra": 0.0},
                  "extra spectator and extra flip apart", extra_starts=({"p_spec": 0.005},
                                                                        {"p_flip": 0.005})))
    main = "extra_preparation"

    def preparation(self, gm, v, prep):
        x = v.get("p_extra", 0.0)
        total = prep.spectator + prep.flip
        f = prep.spectator / total if total > 0 else 0.5
        return dataclasses.replace(prep, spectator=prep.spectator + f * x + v.get("p_spec", 0.0),
                                   flip=prep.flip + (1 - f) * x + v.get("p_flip", 0.0))

    def size_values(self, ctx, p):
        v = self.values(p) or {}
        gate = getattr(ctx, "gate", None)
        out = {"extra_preparation": (v.get("p_extra", 0.0) + v.get("p_spec", 0.0)
                                     + v.get("p_flip", 0.0), "probability",
                                     "preparation error per ion beyond the lab's")}
        if gate is not None:
            pr = gate.preparation(p)
            out.update({
                "spectator": (pr.spectator, "probability", "ion outside the gate, per ion"),
                "flip": (pr.flip, "probability", "ion in the other qubit state, per ion"),
                "preparation_total": (pr.spectator + pr.flip, "probability", "per ion"),
                "e01": (pr.e01, "probability", "detection: bright read dark"),
                "e10": (pr.e10, "probability", "detection: dark read bright")})
        return out


EFFECT = SpamOffset()
