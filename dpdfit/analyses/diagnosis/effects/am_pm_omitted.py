"""``am_pm_omitted``: AM-to-PM conversion left out of the model.

Catalog form ("post"): a phase ``exp(i dphi r^2)``, ``r = |y|/y(1)``, of the
optical field added after the static transfer (``r`` of the forward curve in
use, calibration modes applied).

Variant "aom": the AM-to-PM of the modulator itself, a phase ``dphi_x |x|^2``
of the RF drive amplitude (the form of a phase calibration, Eq. aom-forward).

Both phases change sign with the phase-sign convention of the recorded phase
response.
"""

from __future__ import annotations

from .base import Effect, Param

__all__ = ["AM_PM_OMITTED", "AM_PM_AOM"]

AM_PM_OMITTED = Effect(
    "am_pm_omitted", "tones",
    (Param("dphi", "rad", -1.0, 1.0, 0.0, 0.05),),
    "AM-to-PM conversion left out of the model (phase at full drive ~ |y|^2)",
    form="post", phase_odd=("dphi",))

AM_PM_AOM = Effect(
    "am_pm_omitted", "tones", (Param("dphi_x", "rad", -1.0, 1.0, 0.0, 0.05),),
    "AM-to-PM of the modulator left out of the model: phase dphi_x |x|^2 of the RF drive",
    form="aom", variant=True, phase_odd=("dphi_x",))
