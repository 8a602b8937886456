"""The base class of the diagnosis's candidate effects, and their parameters.

An :class:`Effect` is one *form* of a named extension of the forward model:
its physical parameters (:class:`Param`: unit, bounds, start, scale), the side
of the model it acts on, and the hooks the fit needs -- a seed grid when its
chi2 surface is multimodal, the parameters the phase-sign convention flips,
whether its spectra themselves depend on that sign, the form a campaign
supports (:meth:`Effect.for_campaign`) and derived quantities reported beside
the parameters (:meth:`Effect.derived`).  The physics itself lives in the
forward models (:mod:`dpdfit.analyses.diagnosis.tone_model`,
:mod:`dpdfit.analyses.diagnosis.gate_model`), which read the parameters by
name.  One module of this package per catalog effect holds its catalog form
and its variants; :mod:`dpdfit.analyses.diagnosis.effects.registry` lists them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Param", "Effect"]


@dataclass(frozen=True)
class Param:
    """One physical parameter: name, unit, bounds (flat prior inside), start, step."""

    name: str
    unit: str
    lo: float
    hi: float
    start: float
    scale: float


@dataclass(frozen=True)
class Effect:
    """A named extension of the forward model (one form of a catalog effect).

    Attributes
    ----------
    name : str
        The catalog name (a variant is reported by it, with ``variant`` = its form).
    side : str
        ``"tones"`` or ``"gates"``: the part of the model it changes.
    params : tuple of Param
    meaning : str
    form : str or None
        Name of this form when the catalog effect has several (None: it has one).
    variant : bool
        A second form, fitted beside the catalog form under the key ``name@form``.
    seed_grid : tuple or None
        ``((param a, param b), (grid a, grid b))`` for a multimodal chi2 surface:
        the fit starts from the grid's best point of each sign of ``b``.
    phase_odd : tuple of str
        Parameters that change sign with the phase-sign convention of the recorded
        phase response (an AM-to-PM phase).
    sign_sensitive : bool
        Its spectra are red/blue asymmetric, so they depend on the phase-sign
        convention: it is refitted under the other sign (not only re-predicted).
    """

    name: str
    side: str
    params: tuple
    meaning: str
    form: str | None = None
    variant: bool = False
    seed_grid: tuple | None = None
    phase_odd: tuple = ()
    sign_sensitive: bool = False

    @property
    def key(self) -> str:
        """The name the fits know this form by: ``name``, or ``name@form`` for a variant."""
        return f"{self.name}@{self.form}" if self.variant else self.name

    def for_campaign(self, tone) -> "Effect":
        """This form with the parameters a campaign supports (``tone``: its
        :class:`~dpdfit.analyses.diagnosis.tone_model.ToneModel`)."""
        return self

    def derived(self, tone, p: dict, cov: np.ndarray, names: list) -> tuple[dict, dict]:
        """Quantities reported before the parameters: ``(values, 1-sigma errors)``.

        ``p``: the fitted parameters (all of them, by name), ``cov``: their
        covariance, rows and columns in the order of ``names``.
        """
        return {}, {}
