"""``gate_rate_miscalibration``: the recorded gate rates are off (gate side).

The optical power at gate time differs from the gate-rate calibration by
``eps + slope (A - A_ref)`` dB at drive amplitude ``A`` (``A_ref``: the mean
amplitude of the gate settings); the gate rate is proportional to the field, so
the recorded rate is off by ``10^(-eps/20) - 1``.  Its response is quadratic
and shares the lab's known per-scan jitter and rate-calibration scatter.

Forms: ``offset`` (catalog), ``linear`` (a slope in A).  Priors: flat,
``|eps| <= 3`` dB, ``|slope| <= 5`` dB per unit A.  Sizes: ``rate_error``, the
relative error of the recorded gate rate, ``xi0_recorded / xi0_actual - 1``
at ``A_ref`` (the harness's main quantity), and ``rate_error_slope`` per unit A.
"""

from __future__ import annotations

import numpy as np

from .base import Effect, Form, Param

__all__ = ["GateRateMiscalibration", "EFFECT"]

_LN = np.log(10) / 20


class GateRateMiscalibration(Effect):
    """Recorded gate rates off by an optical-power error ``eps + slope (A - A_ref)``
    dB at gate time (forms ``offset``, ``linear``)."""

    name = "gate_rate_miscalibration"
    side = "gates"
    meaning = "the optical power at gate time differs from the gate-rate calibration"
    params = (Param("eps", "dB", -3.0, 3.0, 0.0, 0.1, "power offset at A_ref"),
              Param("slope", "dB", -5.0, 5.0, 0.0, 0.2, "its change per unit A"))
    forms = (Form("offset", ("eps",), {"slope": 0.0}, "one offset for every setting"),
             Form("linear", ("eps", "slope"), {}, "an offset changing with A",
                  starts_from="offset"))
    main = "rate_error"

    def power_offset_db(self, gm, v, A):
        return v.get("eps", 0.0) + v.get("slope", 0.0) * (np.asarray(A, dtype=float) - gm.A_ref)

    def size_values(self, ctx, p):
        v = self.values(p) or {}
        e = v.get("eps", 0.0)
        return {"rate_error": (10 ** (-e / 20) - 1, "1",
                               "relative error of the recorded gate rate at A_ref"),
                "rate_error_slope": (-_LN * v.get("slope", 0.0) * 10 ** (-e / 20), "1/A",
                                     "its change per unit drive amplitude")}


EFFECT = GateRateMiscalibration()
