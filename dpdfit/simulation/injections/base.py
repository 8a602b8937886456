"""The base class of the simulator's injections: one effect of the catalog put into a
simulated campaign.

An :class:`Injection` names the effect it injects (:attr:`Injection.effect`, an
:class:`~dpdfit.analyses.diagnosis.effects.base.Effect`: what the diagnosis fits) and
carries what only the simulator and the harness need of it:

* how the **campaign simulator injects** it (``inject_*`` hooks, applied by
  :mod:`dpdfit.simulation.campaign`), in every one of the effect's forms;
* the strengths the **harness** draws per form (:attr:`Injection.harness`,
  :attr:`Injection.harness_forms`, :meth:`Injection.draw`);
* which **truth** the harness compares with the diagnosis's sizes
  (:meth:`Injection.truth`, :meth:`Injection.main_size`).

Every hook defaults to "no change", so an injection implements only what it does.  An
effect without an injection of its own is injected by this base class: nothing changes
in the campaign, and the harness does not conceal it (no strengths).

An injection answers for its effect too: an attribute it does not define itself (the
effect's ``name``, forms, parameters, sizes and model hooks) is its effect's, so the
simulator and the harness hold one object per injected effect.  Registering an
injection is one line in :mod:`~dpdfit.simulation.injections.registry` (or a call of
:func:`~dpdfit.simulation.injections.registry.register`).
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.effects import Effect

from .draws import draw_uniform

__all__ = ["Injection"]


class Injection:
    """How the simulator injects one effect (one module per effect).

    Subclasses set :attr:`effect` and the harness's strengths, and override the hooks
    they need.  Injected values reach the hooks as ``v``: a dict of the injection's
    parameters by their own names (:meth:`injected`).
    """

    #: the effect it injects
    effect: Effect | None = None
    #: harness strengths: parameter -> (lo, hi, signed) of its injected value; others at
    #: :meth:`draw`'s defaults
    harness: dict = {}
    #: harness strengths per form (leave-one-form-out harness): form -> {param: (lo, hi,
    #: signed)}; the catalog form's default to :attr:`harness` (:meth:`harness_table`)
    harness_forms: dict = {}
    #: the size the harness compares for forms that do not report the effect's ``main``
    main_forms: dict = {}
    #: campaign references the gate-side injection reads from its values, as the gate
    #: model defines them (``"A_ref"``, ``"t_ref"``); the simulator adds them
    inject_refs: tuple = ()
    #: what ``simulate-campaign --effects NAME=S`` injects: ``(param, unit, meaning)`` of
    #: the one parameter ``S`` sets (the others as :meth:`injected` gives them); empty:
    #: the first :attr:`harness` parameter, else the catalog form's first free one
    strength: tuple = ()

    def __init__(self, effect: Effect | None = None):
        if effect is not None:
            self.effect = effect

    def __getattr__(self, name):
        # only reached for what the injection does not define: its effect's
        if name.startswith("_") or self.effect is None:
            raise AttributeError(name)
        return getattr(self.effect, name)

    # ---------------------------------------------------------------- the harness
    def harness_table(self) -> dict:
        """Harness strengths per form, in the forms' order (:attr:`harness_forms`); a
        form missing here cannot be concealed by the harness."""
        table = dict(self.harness_forms)
        forms = self.effect.forms_for()
        if self.harness and forms:
            table.setdefault(forms[0].name, dict(self.harness))
        return {f.name: table[f.name] for f in forms if f.name in table}

    def form_values(self, form: str) -> dict:
        """Injection values that put the injected effect in ``form`` (besides the drawn
        strengths): the form's fixed parameters that the injection takes."""
        keys = set(self.injection_params())
        return {k: float(x) for k, x in self.effect.form(form).fixed.items() if k in keys}

    def draw(self, rng: np.random.Generator, form: str | None = None) -> dict:
        """Injected values for one harness campaign: each strength parameter uniform in
        its range (a random sign when signed).  ``form`` None: the catalog harness,
        :attr:`harness`, drawn as always; a form: its strengths (:meth:`harness_table`)
        with its other values (:meth:`form_values`), so the effect takes that form."""
        if form is None:
            ranges, v = self.harness, {}
        else:
            table = self.harness_table()
            if form not in table:
                self.effect.form(form)             # a KeyError naming the forms
                raise KeyError(f"{self.effect.name}: form {form!r} has no harness strengths "
                               f"(forms with them: {', '.join(table) or 'none'})")
            ranges, v = table[form], self.form_values(form)
        return draw_uniform(rng, ranges, v)

    def main_size(self, form: str | None = None) -> str:
        """The size the harness compares for an injection in ``form`` (:attr:`main_forms`)."""
        return self.main_forms.get(form, self.effect.main)

    def injected(self, v: dict) -> dict:
        """The complete injected parameter set (the family's parameters not drawn keep
        their catalog form's fixed value, else 0)."""
        forms = self.effect.forms_for()
        fixed = dict(forms[0].fixed) if forms else {}
        return {p.name: float(v.get(p.name, fixed.get(p.name, 0.0))) for p in self.effect.params}

    def injection_params(self) -> tuple:
        """The parameters the injection takes (default: those :meth:`injected` gives)."""
        return tuple(self.injected({}))

    def strength_of(self) -> tuple:
        """``(param, unit, meaning)`` of :attr:`strength` (default: see there)."""
        if self.strength:
            return tuple(self.strength)
        name = next(iter(self.harness), None) or self.effect.forms_for()[0].free[0]
        p = next((p for p in self.effect.parameters() if p.name == name), None)
        return (name, p.unit, p.meaning) if p else (name, "", "")

    def truth(self, v: dict, sim_truth: dict, ctx=None) -> dict:
        """The injected size in the terms of the effect's ``size_values`` (what the
        harness compares); default: ``size_values`` of the injected values (``ctx``: the
        diagnosis's problem, for the campaign's own scales)."""
        p = {self.effect.key(k): x for k, x in self.injected(v).items()}
        return {k: val for k, (val, _, _) in self.effect.size_values(ctx, p).items()}

    # ---------------------------------------------------------------- the simulator
    def inject_drive(self, v: dict, x: np.ndarray, fs: float) -> np.ndarray:
        """Simulator: the complex drive envelope (one period at ``fs``) before the AOM."""
        return x

    def inject_field(self, v: dict, y: np.ndarray, x: np.ndarray, fs: float,
                     y_full: float) -> np.ndarray:
        """Simulator: the optical field after the AOM (drive ``x``; ``y_full`` its
        field at full drive)."""
        return y

    def inject_photodiode(self, v: dict, power: np.ndarray, p_full: float) -> np.ndarray:
        """Simulator: the calibration photodiode's reading of the true ``power``."""
        return power

    def inject_aom(self, v: dict, days_after_table: np.ndarray,
                   days_after_recording: np.ndarray) -> np.ndarray:
        """Simulator: relative change of the AOM's ``A_corr`` at calibration runs and
        recordings (arrays of days after the table's run and after the recordings;
        the recordings themselves are at 0)."""
        return np.zeros(np.shape(days_after_table))

    def inject_rf_gain(self, v: dict, days_after_table: np.ndarray,
                       days_after_recording: np.ndarray) -> np.ndarray:
        """Simulator: relative change of the RF gain ahead of the AOM, as
        :meth:`inject_aom` (a drift of another shape than ``A_corr``'s)."""
        return np.zeros(np.shape(days_after_table))

    def inject_phase_run(self, v: dict, A: np.ndarray) -> np.ndarray:
        """Simulator: extra phase (rad) of the AOM's own transfer at drive amplitudes
        ``A`` that a phase run taken after the recordings records (the AOM as it is at
        the recordings; the runs before them, the model's among them, do not have it)."""
        return np.zeros(np.shape(A))

    def inject_table(self, v: dict) -> float:
        """Simulator: relative change of ``A_corr`` of the calibration the predistortion
        table was built from, against the run the records name (0: that run's)."""
        return 0.0

    def inject_engine(self, v: dict, kw: dict, A: float) -> dict:
        """Simulator: the gate engine's keyword arguments at a setting of amplitude
        ``A`` (``nbar``, ``T2``, ``T2_corr``, ``ndot``, ``p_prep``, ``p_flip``,
        ``p_det``, ``power_error_db``, ``dephasing_profile``)."""
        return kw

    def inject_coherence(self, v: dict, t_gate: float):
        """Simulator: factors ``(k1, k2)`` of the final state's single-ion and
        ``|00><11|`` coherences after a gate of ``t_gate`` (s), as the effect's
        ``coherence`` (None: no such decay)."""
        return None
