"""The free parameters of a fit: each one's name, value, bounds and scale in one object.

A fit of the model (a hypothesis's,
:mod:`~dpdfit.analyses.diagnosis.fitting.least_squares`; the gate-rate scatter's,
:mod:`~dpdfit.analyses.diagnosis.model.gates.rate_scatter`) varies a vector ``x`` in
the order of its :class:`Parameters`, and scipy's ``least_squares`` takes their
values, bounds and scales as arrays (:attr:`Parameters.values`,
:attr:`~Parameters.lower`, :attr:`~Parameters.upper`, :attr:`~Parameters.scales`).
Once fitted, each :class:`Parameter` also says whether the fit stopped on a bound
and holds its 1-sigma error
(:attr:`~dpdfit.analyses.diagnosis.fitting.fit_result.FitResult.parameters`).

An effect's :class:`~dpdfit.analyses.diagnosis.effects.base.Param` declares a
parameter of its family (unit, bounds, start, scale, meaning); a :class:`Parameter`
is a nuisance or effect parameter free in one particular fit, under the fits' name.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

__all__ = ["Parameter", "Parameters"]


@dataclass(frozen=True)
class Parameter:
    """One free parameter of a fit."""

    #: the fits' name: a nuisance's, or ``"<effect>.<param>"``
    name: str
    #: its starting value before a fit, its optimum after
    value: float
    #: its lower and upper bound
    lo: float
    hi: float
    #: a typical step: the trust region's scale and the finite-difference steps
    scale: float
    #: the fit stopped on ``lo`` or ``hi`` (:meth:`on_bound`)
    at_bound: bool = False
    #: its 1-sigma error from the fit's covariance (NaN before a fit, and at a bound,
    #: where the curvature says nothing)
    error: float = float("nan")

    def on_bound(self, x: float) -> bool:
        """Whether ``x`` sits on ``lo`` or ``hi`` (to ``1e-9`` of the bound's size, at
        least ``1e-9``)."""
        return bool(np.isclose(x, self.lo, rtol=0, atol=1e-9 * np.maximum(1, np.abs(self.lo)))
                    | np.isclose(x, self.hi, rtol=0,
                                 atol=1e-9 * np.maximum(1, np.abs(self.hi))))


@dataclass(frozen=True)
class Parameters:
    """The free parameters of one fit, in the order of the vector ``x`` the fit varies
    and of its covariance.  Iterating gives each :class:`Parameter`; ``parameters[name]``
    the one called ``name``."""

    members: tuple[Parameter, ...] = ()

    def __iter__(self):
        return iter(self.members)

    def __len__(self) -> int:
        return len(self.members)

    def __getitem__(self, name: str) -> Parameter:
        return self.members[self.index(name)]

    def index(self, name: str) -> int:
        """The position of parameter ``name`` in ``x`` (ValueError when it is not free)."""
        return self.names.index(name)

    @property
    def names(self) -> tuple[str, ...]:
        """Their names, in order."""
        return tuple(p.name for p in self.members)

    @property
    def values(self) -> np.ndarray:
        """Their values as an array (a fit's starting point before it, its optimum after)."""
        return np.array([p.value for p in self.members], dtype=float)

    @property
    def lower(self) -> np.ndarray:
        """Their lower bounds as an array."""
        return np.array([p.lo for p in self.members], dtype=float)

    @property
    def upper(self) -> np.ndarray:
        """Their upper bounds as an array."""
        return np.array([p.hi for p in self.members], dtype=float)

    @property
    def scales(self) -> np.ndarray:
        """Their scales as an array."""
        return np.array([p.scale for p in self.members], dtype=float)

    def at(self, x) -> Parameters:
        """The same parameters with the values ``x`` (in their order)."""
        return Parameters(tuple(dataclasses.replace(p, value=v)
                                for p, v in zip(self.members, x, strict=True)))

    def at_optimum(self, x) -> Parameters:
        """The same parameters at a fit's optimum ``x``, each flagged when it sits on a
        bound."""
        return Parameters(tuple(dataclasses.replace(p, value=v, at_bound=p.on_bound(v))
                                for p, v in zip(self.members, x, strict=True)))
