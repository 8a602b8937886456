"""The diagnosis's catalog of candidate effects, one module per effect (issue #7).

Each catalog effect is a named extension of the forward model with physical
parameters, units and bounds (flat priors inside them), described in its own
module with its variants (second forms fitted beside it).  Tone-side effects
change the field the waveform produces (:mod:`.am_pm_omitted`,
:mod:`.aom_memory`, :mod:`.stale_calibration`, :mod:`.higher_order_im`,
:mod:`.detector_nonlinearity`); gate-side effects change the gate observables
through the engine's linear response (:mod:`.dephasing`,
:mod:`.motional_heating`, :mod:`.spam_offset`, :mod:`.gate_rate_miscalibration`,
:mod:`.higher_nbar`).  :class:`~.base.Effect` is their base class,
:mod:`.registry` lists them in ``EFFECTS`` and ``VARIANTS``.
"""

from .base import Effect, Param
from .registry import (EFFECTS, PHASE_ODD_PARAMS, TONE_PARAMS, VARIANTS, effect_form,
                       form_key, forms_of)
from .stale_calibration import STALE_AOM

__all__ = ["Param", "Effect", "EFFECTS", "VARIANTS", "STALE_AOM", "TONE_PARAMS",
           "PHASE_ODD_PARAMS", "effect_form", "forms_of", "form_key"]
