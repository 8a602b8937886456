"""``am_pm_omitted``: AM-to-PM conversion left out of the model.

Family: a phase that grows with the drive, in one of two places.

* form ``post`` (catalog): ``exp(i dphi r^2)``, ``r = |y|/y(1)``, after the
  static transfer (beam path after the calibrated AOM; ``r`` of the forward
  curve in use, calibration modes applied);
* form ``aom``: the modulator's own AM-to-PM, a phase ``dphi_x |x|^2`` of the RF
  drive amplitude (the form of a phase calibration, Eq. S11).  It
  replaces the baseline's nuisance ``pm_x`` (a campaign without a phase file
  has its AOM's phase as a nuisance with a narrow prior);
* form ``aom_quartic`` (a campaign without a phase calibration: with one, the
  AOM's phase polynomial is in the lab's model and only a small residual of the
  lowest order can be missing): the same to the next even order,
  ``dphi_x |x|^2 + dphi_x4 |x|^4``: the AOM's phase is a smooth even function
  of the drive amplitude, which a phase calibration fits as a polynomial, so
  its lowest term alone need not describe it (replaces ``pm_x`` too).

Priors: flat, ``|dphi|, |dphi_x|, |dphi_x4| <= 1`` rad.  Size: the phase at full drive
(rad).  Both phases change sign with the phase-sign convention of the
recorded phase response.
"""

from __future__ import annotations

import numpy as np

from .base import Effect, Form, Param

__all__ = ["AmPmOmitted", "EFFECT"]


class AmPmOmitted(Effect):
    """Missing AM-to-PM conversion: a phase growing with the drive, after the
    AOM (``post``, catalog) or in the AOM itself (``aom``); see the module."""

    name = "am_pm_omitted"
    side = "tones"
    meaning = "AM-to-PM conversion left out of the model (phase at full drive ~ |y|^2)"
    params = (Param("dphi", "rad", -1.0, 1.0, 0.0, 0.05, "phase at full drive after the AOM"),
              Param("dphi_x", "rad", -1.0, 1.0, 0.0, 0.05,
                    "the AOM's own phase at full drive (|x|^2 of the RF drive)"),
              Param("dphi_x4", "rad", -1.0, 1.0, 0.0, 0.05,
                    "its next even order at full drive (|x|^4 of the RF drive)"))
    forms = (Form("post", ("dphi",), {"dphi_x": 0.0, "dphi_x4": 0.0},
                  "phase ~ |y|^2 after the AOM"),
             Form("aom", ("dphi_x",), {"dphi": 0.0, "dphi_x4": 0.0},
                  "the modulator's own AM-to-PM", replaces=("pm_x",)),
             Form("aom_quartic", ("dphi_x", "dphi_x4"), {"dphi": 0.0},
                  "the modulator's own AM-to-PM to the next even order of the drive",
                  replaces=("pm_x",), starts_from="aom", extra_starts=({"dphi_x4": -0.1},
                                                                       {"dphi_x4": 0.1})))
    phase_odd = ("dphi", "dphi_x", "dphi_x4")
    stage = 1
    main = "am_pm_rad"

    def forms_for(self, ctx=None):
        """Every form without a phase calibration; with one, not ``aom_quartic``: the
        AOM's phase polynomial is then in the lab's model to the calibration's
        precision, and what can be missing from it is a small residual of the lowest
        even order (``aom``), not a free polynomial (a phase calibration that no longer
        matches the AOM is a stale calibration)."""
        prior = getattr(ctx, "prior", None)
        if prior is None or "pm_x" in prior:
            return self.forms
        return tuple(f for f in self.forms if f.name != "aom_quartic")

    def coefficients(self, tm, v, cy, cp):
        if not (v.get("dphi_x") or v.get("dphi_x4")):
            return cy, cp
        cp = np.concatenate([cp, np.zeros(max(5 - cp.size, 0))])
        cp[2] += v.get("dphi_x", 0.0)
        cp[4] += v.get("dphi_x4", 0.0)
        return cy, cp

    def transfer(self, tm, v, y, cy):
        if not v.get("dphi"):
            return y
        r2 = (np.abs(y) / np.polynomial.polynomial.polyval(1.0, cy)) ** 2
        return y * np.exp(1j * v["dphi"] * r2)

    def size_values(self, ctx, p):
        v = self.values(p) or {}
        return {"am_pm_rad": (v.get("dphi", 0.0) + v.get("dphi_x", 0.0)
                              + v.get("dphi_x4", 0.0), "rad",
                              "missing AM-to-PM phase at full drive")}


EFFECT = AmPmOmitted()
