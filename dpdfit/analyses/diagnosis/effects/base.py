"""The base class of the diagnosis's candidate effects: parameters, forms and behaviour.

An :class:`Effect` is one named piece of physics a laboratory may have left
out of its model.  Its module carries everything about it (the pattern of
emcee's ``moves/``):

* its **family of parameters** (:class:`Param`: unit, bounds = a flat prior,
  start and step) in its own namespace -- a fit knows them as
  ``"<effect>.<param>"`` -- and its **forms** (:class:`Form`): nested members
  of the family, each freeing some parameters and fixing the others, so that
  a family's extra parameters are charged by BIC only when a form uses them;
* what it does to the **optical field** (tone side): the static transfer's
  coefficients (:meth:`Effect.coefficients`), the calibration the
  predistortion table was built from (:meth:`Effect.table_curve`), the
  memoryless transfer after the static curve (:meth:`Effect.transfer`), a
  linear filter of the drive (:meth:`Effect.drive_filter`) or a gain that
  follows the filtered drive power (:meth:`Effect.power_memory`);
* what it does to the **gate dynamics and counts** (gate side): linear
  responses of the exact engine to perturbations of its inputs
  (:meth:`Effect.knobs`, :class:`Knob`, weighted per observation time by
  :meth:`Effect.knob_coefficients`), a power offset at each gate setting
  (:meth:`Effect.power_offset_db`), preparation and detection errors
  (:meth:`Effect.preparation`);
* its **size in a laboratory's terms** (:meth:`Effect.size_values`, with
  errors by :meth:`Effect.sizes`).

Every hook defaults to "no change", so an effect implements only what it
does.  The forward models (:mod:`~dpdfit.analyses.diagnosis.model.tones.tone_model`,
:mod:`~dpdfit.analyses.diagnosis.model.gates.gate_model`) call the hooks of the effects
present; nothing outside an effect's module knows its parameters.  How the
campaign simulator injects an effect, the strengths the harness draws and the
truth it compares live with the simulator, one module per effect
(:mod:`dpdfit.simulation.injections`).  Registering an effect is one line in
:mod:`~dpdfit.analyses.diagnosis.effects.registry` (or a call of
:func:`~dpdfit.analyses.diagnosis.effects.registry.register`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from .delta_method import delta_method_errors

__all__ = ["Param", "Form", "Knob", "Prep", "Size", "Effect", "SIDES"]

#: the two sides of the forward model an effect can act on
SIDES = ("tones", "gates")


@dataclass(frozen=True)
class Param:
    """One parameter of an effect's family.

    ``lo``/``hi`` bound it (a flat prior in between); ``start`` is where fits
    begin, ``scale`` a typical step (the fits' finite-difference and trust-region
    scale), ``meaning`` one line for the catalog.
    """

    name: str
    unit: str
    lo: float
    hi: float
    start: float
    scale: float
    meaning: str = ""


@dataclass(frozen=True)
class Form:
    """One member of an effect's family: ``free`` parameters are fitted, ``fixed``
    holds the others; ``seed_grid`` = ``((param a, param b), (values a, values b))``
    starts a multimodal fit from the best grid point of each sign of ``b``."""

    name: str
    free: tuple
    fixed: dict = field(default_factory=dict)
    meaning: str = ""
    seed_grid: tuple | None = None
    #: nuisances this form replaces (held at their prior centre while it is fitted)
    replaces: tuple = ()
    #: the smaller form whose optimum starts this one (nested families), and further
    #: starting values of the parameters it adds
    starts_from: str | None = None
    extra_starts: tuple = ()


@dataclass(frozen=True)
class Knob:
    """A perturbation of the gate engine's inputs whose linear response the gate
    model computes at every setting and scan time: ``perturb(nominal, step)``
    returns the engine's keyword arguments (``nbar``, ``T2``, ``ndot``,
    ``T2_corr``) moved by ``step`` (in ``unit``).  Effects sharing a knob give it
    the same ``key``."""

    key: str
    step: float
    unit: str
    perturb: Callable
    #: the response is far from linear over the range fitted (a coherence that decays
    #: exponentially): the engine is also run at three steps (:mod:`~dpdfit.analyses.diagnosis.model.gates.gate_model`)
    nonlinear: bool = False


@dataclass(frozen=True)
class Prep:
    """Preparation and detection errors per ion: ``spectator`` (a level outside
    the gate, reads bright), ``flip`` (the other qubit state, driven), ``e01``
    (bright read dark), ``e10`` (dark read bright)."""

    spectator: float
    flip: float
    e01: float
    e10: float


@dataclass(frozen=True)
class Size:
    """An effect's size in a laboratory's terms, with its 1-sigma error."""

    name: str
    value: float
    error: float
    unit: str
    meaning: str = ""

    def to_dict(self) -> dict:
        """The size as a JSON-ready dict: ``value``, ``error``, ``unit``, ``meaning``."""
        return {"value": self.value, "error": self.error, "unit": self.unit,
                "meaning": self.meaning}


class Effect:
    """A named extension of the forward model (one module per effect).

    Subclasses set the class attributes and override the hooks they need.
    Parameter values reach the hooks as ``v``: a dict of the family's
    parameters by their own names (free and fixed ones of the form in use).
    """

    #: catalog name (a verdict name)
    name: str = ""
    #: ``"tones"`` or ``"gates"``: the part of the model it changes
    side: str = "tones"
    #: one line: what is missing
    meaning: str = ""
    #: the family's parameters
    params: tuple = ()
    #: its forms, the catalog form first (if empty, one form with every parameter free)
    forms: tuple = ()
    #: considered by ``diagnose`` unless the caller names the effects
    default: bool = True
    #: parameters that change sign with the phase-sign convention of the recorded phase
    phase_odd: tuple = ()
    #: its spectra depend on that convention (red/blue asymmetric): refitted under both
    sign_sensitive: bool = False
    #: order among the transfer hooks (smaller first: the static curve before the beam path)
    stage: int = 1
    #: parameters that move the predistortion table only (the DPD-off spectra stay cached)
    table_only: tuple = ()
    #: the quantity whose pull the harness reports (a key of :meth:`size_values`)
    main: str = ""

    # ---------------------------------------------------------------- parameters
    def key(self, param: str) -> str:
        """The fit's name of one of the family's parameters."""
        return f"{self.name}.{param}"

    def parameters(self, ctx=None) -> tuple:
        """The family's parameters for a campaign (``ctx``: its forward model or None)."""
        return self.params

    def forms_for(self, ctx=None) -> tuple:
        """The forms a campaign supports (default: :attr:`forms`, else one with every
        parameter free)."""
        return self.forms or (Form("catalog", tuple(p.name for p in self.parameters(ctx))),)

    def form(self, name: str | None, ctx=None) -> Form:
        """The form called ``name`` (None: the catalog form)."""
        forms = self.forms_for(ctx)
        if name is None:
            return forms[0]
        for f in forms:
            if f.name == name:
                return f
        raise KeyError(f"{self.name} has no form {name!r} (forms: "
                       f"{', '.join(f.name for f in forms)})")

    def param(self, name: str, ctx=None) -> Param:
        """The family's parameter named ``name`` (``ctx``: the campaign's forward model,
        for families whose parameters depend on it)."""
        return next(p for p in self.parameters(ctx) if p.name == name)

    def values(self, p: dict, ctx=None) -> dict | None:
        """This effect's parameter values in the parameter set ``p`` (its own names),
        or None when it is absent from ``p``."""
        prefix = self.name + "."
        v = {k[len(prefix):]: float(x) for k, x in p.items() if k.startswith(prefix)}
        return v or None

    def supports(self, ctx) -> bool:
        """Whether the campaign gives this effect something to act on."""
        return True

    # ---------------------------------------------------------------- tone side
    def coefficients(self, tm, v: dict, cy: np.ndarray, cp: np.ndarray):
        """The static transfer's coefficient vectors ``(cy, cp)`` (index = power of
        the drive amplitude) as changed by this effect."""
        return cy, cp

    def table_curve(self, tm, v: dict, cy: np.ndarray):
        """The amplitude calibration the predistortion table was built from (None:
        the recorded one, unchanged)."""
        return None

    def transfer(self, tm, v: dict, y: np.ndarray, cy: np.ndarray) -> np.ndarray:
        """The field ``y`` of the static transfer (curve ``cy``) as changed after it,
        sample by sample (no memory)."""
        return y

    def detector_reading(self, tm, v: dict, u: np.ndarray, inverse: bool = False):
        """The calibration photodiode's reading of the relative true power ``u`` (in
        units of the amplitude curve's largest reading ``P_max``); with ``inverse``, the
        true power of the reading ``u``.  What a detector linearity characterisation
        sees (:mod:`~dpdfit.analyses.diagnosis.model.linearity_block`); default: a
        linear photodiode, ``u`` either way."""
        return u

    def drive_filter(self, tm, v: dict, f: np.ndarray):
        """A linear filter ``H(f)`` of the complex drive envelope before the static
        transfer (None: none; needs the time-domain field)."""
        return None

    def power_memory(self, tm, v: dict, f: np.ndarray):
        """``(gain, H(f))``: the field is multiplied by ``1 + gain s(t)``, ``s`` the
        drive power ``|x|^2`` through the filter ``H`` (None: no such memory)."""
        return None

    # ---------------------------------------------------------------- gate side
    def knobs(self) -> tuple:
        """The engine perturbations whose linear responses this effect combines."""
        return ()

    def knob_coefficients(self, gm, v: dict, t: np.ndarray) -> dict:
        """Weights of the knobs' per-unit responses at observation times ``t`` (s):
        ``{knob key: array like t}``."""
        return {}

    def coherence(self, gm, v: dict, t: np.ndarray):
        """Factors ``(k1, k2)`` (arrays like ``t``) by which the final two-ion state's
        single-ion and two-ion coherences decay at gate time ``t``, its populations
        untouched (None: no such decay)."""
        return None

    def free_dephasing(self, gm, v: dict, t: np.ndarray, echo: bool):
        """``(G_independent, G_common)`` (arrays like ``t``): each ion's accumulated
        dephasing over a free-precession wait ``t`` (s) of the Ramsey sequence, or of the
        spin echo with ``echo`` (``ramsey.csv``; :mod:`dpdfit.models.ramsey` says what the
        echo removes), beyond the lab's stated T2 (None: no such dephasing)."""
        return None

    def power_offset_db(self, gm, v: dict, A: np.ndarray) -> np.ndarray:
        """Optical power offset (dB) at gate time at drive amplitudes ``A``."""
        return np.zeros(np.shape(A))

    def preparation(self, gm, v: dict, prep: Prep) -> Prep:
        """Preparation and detection errors as changed by this effect."""
        return prep

    # ---------------------------------------------------------------- other data
    def run_drift(self, ctx, v: dict, days_after: np.ndarray):
        """Shift of the calibration runs recorded after the recordings, in units of
        the run-to-run drift modes' sd: shape ``(len(days_after), n modes)`` (None:
        this effect does not move them)."""
        return None

    # ---------------------------------------------------------------- its size
    def size_values(self, ctx, p: dict) -> dict:
        """Its size in a laboratory's terms from the fitted parameter set ``p`` (every
        parameter of the hypothesis, nuisances included, by the fits' names):
        ``{name: (value, unit, meaning)}``."""
        return {}

    def sizes(self, ctx, p: dict, cov: np.ndarray | None, free: list, scales: list) -> dict:
        """:meth:`size_values` with 1-sigma errors by the delta method: numerical
        gradient over the fitted parameters ``free`` (steps of ``1e-4`` x their
        ``scales``), covariance ``cov`` in their order."""
        base = self.size_values(ctx, p)
        errs = delta_method_errors(lambda q: self.size_values(ctx, q), p, cov, free, scales)
        return {k: Size(k, *errs[k], unit, meaning) for k, (_, unit, meaning) in base.items()}
