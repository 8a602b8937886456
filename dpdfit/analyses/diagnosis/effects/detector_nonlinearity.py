"""``detector_nonlinearity``: the calibration photodiode read ``P (1 + k u^q)``,
``u = P/P_max``.

The true transfer is the corrected one while the table was built from the
distorted one.  Family: form ``linear`` (catalog, ``q = 1``: saturation or
expansion) and form ``power`` (``q`` free: a nonlinearity of another order).
A nonlinear detector bends every calibration run alike, so it leaves no
run-to-run signature (unlike a stale calibration, which moves the runs taken
after the recordings).

Priors: flat, ``|k| <= 0.5``, ``0.3 <= q <= 4``.  Size: ``k_det``, the relative
reading error at the curve's maximum (true) power, reading / true - 1 there (``k``
itself is relative to the largest reading: ``k_det = k / (1 + k)`` for ``q = 1``), and
the exponent ``q``.
"""

from __future__ import annotations

import numpy as np

from .base import Effect, Form, Param

__all__ = ["DetectorNonlinearity", "EFFECT", "NEWTON_STEPS", "true_over_read"]

#: Newton steps of the inversion for exponents q != 1 (a fixed number keeps the model
#: smooth in k and q for the fits' finite differences)
NEWTON_STEPS = 5


def true_over_read(u, k, q):
    """``u_true / u_read`` for readings ``u_read = u_true (1 + k u_true^q)``."""
    # q = 1 root, rationalised: no cancellation as k -> 0, where the fits probe it
    ratio = 2.0 / (1.0 + np.sqrt(np.maximum(1 + 4 * k * u, 0.0)))
    if q != 1.0:
        um = np.maximum(u, 1e-300)
        ut = ratio * um
        for _ in range(NEWTON_STEPS):
            ut = np.maximum(ut - (ut + k * ut ** (q + 1) - um) / (1 + k * (q + 1) * ut ** q),
                            0.0)
        ratio = ut / um
    return ratio


class DetectorNonlinearity(Effect):
    """A nonlinear calibration photodiode, read ``P (1 + k (P/P_max)^q)``: the
    table was built from the distorted curve (forms ``linear``, ``power``)."""

    name = "detector_nonlinearity"
    side = "tones"
    meaning = ("calibration photodiode read P (1 + k (P/P_max)^q): the table was built from "
               "a distorted calibration")
    params = (Param("k", "1/P_max", -0.5, 0.5, 0.0, 0.02, "relative reading error at P_max"),
              Param("q", "1", 0.3, 4.0, 1.0, 0.1, "exponent of the reading error"))
    forms = (Form("linear", ("k",), {"q": 1.0}, "reading error ~ P (saturation)"),
             Form("power", ("k", "q"), {}, "reading error ~ P^q", starts_from="linear",
                  extra_starts=({"q": 2.0}, {"q": 0.6})))
    stage = 0
    main = "k_det"

    def transfer(self, tm, v, y, cy):
        k = v.get("k", 0.0)
        if not k:
            return y
        # P/P_max of *this* curve (calibration modes applied): a scale frozen at the
        # fitted curve would move k with every mode that moves y(1)
        u = (np.abs(y) / tm.y_max(cy)) ** 2
        return y * np.sqrt(true_over_read(u, k, v.get("q", 1.0)))

    def detector_reading(self, tm, v, u, inverse=False):
        # the same reading u_true (1 + k u_true^q) whose inverse the transfer applies
        k, q = v.get("k", 0.0), v.get("q", 1.0)
        u = np.asarray(u, dtype=float)
        if inverse:
            return u * true_over_read(u, k, q)
        return u * (1 + k * np.maximum(u, 0.0) ** q)

    def size_values(self, ctx, p):
        v = self.values(p) or {}
        k, q = v.get("k", 0.0), v.get("q", 1.0)
        # k is relative to the curve's largest *reading*; the lab's figure is the reading
        # error at the largest *true* power, whose reading that is: read/true - 1 there
        k_full = 1.0 / float(true_over_read(np.array(1.0), k, q)) - 1.0
        return {"k_det": (k_full, "1", "relative reading error at the maximum power "
                                       "(reading / true power - 1 at full drive)"),
                "q": (v.get("q", 1.0), "1", "exponent of the reading error")}


EFFECT = DetectorNonlinearity()
