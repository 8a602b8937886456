"""The catalog of candidate effects: every effect module's forms, by name.

``EFFECTS`` maps each catalog name to its catalog form; ``VARIANTS`` maps
``name@form`` to the second forms fitted beside them.  The diagnosis names the
better of an effect's forms by the catalog name (``variant`` in its ranking
entry).  A second parameter is a variant, not part of the catalog form, so
that a one-parameter effect is not charged for it by BIC when it is not
needed.  Adding an effect: a module beside this one defining its
:class:`~dpdfit.analyses.diagnosis.effects.base.Effect` forms, listed here
(the order is the order of the fits and of the reports).
"""

from __future__ import annotations

from .am_pm_omitted import AM_PM_AOM, AM_PM_OMITTED
from .aom_memory import AOM_MEMORY, AOM_MEMORY_THERMAL
from .base import Effect
from .dephasing import DEPHASING, DEPHASING_CORRELATED
from .detector_nonlinearity import DETECTOR_NONLINEARITY
from .gate_rate_miscalibration import GATE_RATE_MISCALIBRATION
from .higher_nbar import HIGHER_NBAR
from .higher_order_im import HIGHER_ORDER_IM
from .motional_heating import MOTIONAL_HEATING, MOTIONAL_HEATING_INITIAL
from .spam_offset import SPAM_OFFSET
from .stale_calibration import STALE_AOM, STALE_CALIBRATION

__all__ = ["EFFECTS", "VARIANTS", "TONE_PARAMS", "PHASE_ODD_PARAMS", "effect_form",
           "forms_of", "form_key"]

#: catalog effects: name -> catalog form
EFFECTS = {e.key: e for e in (
    AM_PM_OMITTED, AOM_MEMORY, STALE_CALIBRATION, HIGHER_ORDER_IM, DETECTOR_NONLINEARITY,
    DEPHASING, MOTIONAL_HEATING, SPAM_OFFSET, GATE_RATE_MISCALIBRATION, HIGHER_NBAR)}

#: second forms of catalog effects: "name@form" -> form
VARIANTS = {e.key: e for e in (
    STALE_AOM, AM_PM_AOM, DEPHASING_CORRELATED, MOTIONAL_HEATING_INITIAL, AOM_MEMORY_THERMAL)}

#: parameters of the tone side (effects), which the tone model's cache is keyed on
TONE_PARAMS = tuple(dict.fromkeys(par.name for e in (*EFFECTS.values(), *VARIANTS.values())
                                  if e.side == "tones" for par in e.params))

#: parameters that change sign with the phase-sign convention of the recorded phase response
PHASE_ODD_PARAMS = tuple(dict.fromkeys(k for e in (*EFFECTS.values(), *VARIANTS.values())
                                       for k in e.phase_odd))


def effect_form(key: str) -> Effect:
    """The catalog form (``key`` = a name) or the variant (``key`` = ``name@form``)."""
    return VARIANTS[key] if key in VARIANTS else EFFECTS[key]


def forms_of(name: str) -> list:
    """Every form of the catalog effect ``name``: its catalog form, then its variants."""
    return [EFFECTS[name]] + [v for v in VARIANTS.values() if v.name == name]


def form_key(name: str, form: str | None) -> str:
    """The key of effect ``name``'s form ``form`` (its catalog form's key, ``name``, for
    None or the catalog form)."""
    key = f"{name}@{form}"
    return key if key in VARIANTS else name
