"""Effects the recordings do not see: an addition whose size is consistent with zero is an
upper limit on that effect, not a rival of the named effects.

An addition in reach
(:func:`~dpdfit.analyses.diagnosis.decisions.alternatives.addition_alternatives`) is the
named effects plus one more.  When the added effect's fitted main size is
consistent with zero -- its magnitude at most
:data:`~dpdfit.analyses.diagnosis.evidence.thresholds.ZERO_Z` standard deviations -- the
recordings do not see that effect: what they say about it is how large it can be, and a
further recording could only shrink that bound, never settle a rivalry.  Such an
alternative is reported as an :class:`UpperLimit` on the effect's main size
(``stale_calibration [table] |y1 drift| < 0.0003 (95 %)``), and the alternatives that remain are the open ones, rivals with
support of their own, which the proposal aims at
(:func:`~dpdfit.analyses.diagnosis.proposal.propose.propose`).

The standard deviation is the statistical error of the size in the joint fit (the
profile likelihood where a parameter sits at a bound,
:func:`~dpdfit.analyses.diagnosis.fitting.likelihood_intervals.profile_errors`) times
``sqrt(tempering)``, the dispersion of the addition's evidence, as for a named effect's
size (:mod:`~dpdfit.analyses.diagnosis.evidence.form_errors`).  Swaps, and additions that a
form of a named family leaves no room for (``room``), are never bounded: the first are
other causes, the second patch a named family's form.

A bound is only as good as the model it comes from.  Where the addition's fit leaves a
dispersion of the evidence (``tempering``) above
:data:`~dpdfit.analyses.diagnosis.evidence.thresholds.NULL_REDCHI_MAX`, the most any
observable of a campaign with nothing concealed shows, the recordings are not described
well enough for the fitted size to be trusted near zero (a size fitted through a misfit
can sit far from the truth with a small error): the addition then stays an open
alternative.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.analyses.diagnosis.evidence.thresholds import LIMIT_LEVEL, NULL_REDCHI_MAX, ZERO_Z
from dpdfit.analyses.diagnosis.fitting.likelihood_intervals import profile_errors
from dpdfit.core.records import Record

__all__ = ["UpperLimit", "split_upper_limits", "upper_limit_of", "ZERO_Z", "LIMIT_LEVEL"]


@dataclass(frozen=True)
class UpperLimit(Record):
    """An effect the recordings do not see, bounded: the magnitude of its main size is
    below :attr:`limit` at confidence :attr:`level` (module doc)."""

    #: the effect bounded
    effect: str
    #: the form it was fitted in, added to the named effects
    form: str
    #: its main size (:attr:`~dpdfit.analyses.diagnosis.effects.base.Effect.main`)
    quantity: str
    #: the size fitted with the named effects, and its standard deviation (statistical,
    #: times ``sqrt(tempering)``)
    value: float
    sigma: float
    #: the bound on ``|value|``: ``|value| + ZERO_Z sigma``
    limit: float
    #: its confidence level
    level: float
    #: the size's unit (``"1"``: a ratio) and meaning
    unit: str
    meaning: str
    #: the named effects plus it: the hypothesis the limit comes from
    named: tuple
    #: that hypothesis's evidence against the named one, as an alternative has it
    delta_bic: float
    delta_bic_tempered: float
    tempering: float

    @classmethod
    def from_dict(cls, d: dict) -> "UpperLimit":
        """The upper limit of a JSON entry (:meth:`to_dict`), e.g. of an earlier diagnosis."""
        return cls(d["effect"], d["form"], d["quantity"], d["value"], d["sigma"], d["limit"],
                   d["level"], d["unit"], d.get("meaning", ""),
                   tuple(d.get("named") or [d["effect"]]), d["delta_bic"],
                   d["delta_bic_tempered"], d["tempering"])

    def to_dict(self) -> dict:
        """The JSON's entry of ``upper_limits``: every attribute (``named`` a list)."""
        out = super().to_dict()
        out["named"] = list(self.named)
        return out

    def text(self) -> str:
        """The limit in words, e.g. ``"stale_calibration [table] |y1 drift| < 0.00031 (95 %)"``."""
        unit = "" if self.unit in ("", "1") else f" {self.unit}"
        return (f"{self.effect} [{self.form}] |{self.quantity.replace('_', ' ')}| < "
                f"{self.limit:.2g}{unit} ({100 * self.level:.0f} %)")


def upper_limit_of(prob, alternative, fit) -> UpperLimit | None:
    """The :class:`UpperLimit` an alternative stands for, or None when it is open: a swap,
    an addition some form leaves no room for, one whose added effect's main size is not
    consistent with zero (or has no finite error to judge it by), or one whose fit does
    not describe the recordings well enough to bound it (tempering above
    :data:`~dpdfit.analyses.diagnosis.evidence.thresholds.NULL_REDCHI_MAX`).  ``fit``: the
    alternative's fit (the named effects plus the added one)."""
    a = alternative
    c = a.effect
    if a.is_swap or a.room is not None or c not in fit.effects:
        return None
    main = EFFECTS[c].main
    size = profile_errors(prob, fit, c).get(main) if main else None
    if size is None or not (np.isfinite(size.value) and np.isfinite(size.error)):
        return None
    tau = max(float(a.tempering), 1.0)
    if tau > NULL_REDCHI_MAX:
        return None
    sigma = float(size.error) * float(np.sqrt(tau))
    if abs(size.value) > ZERO_Z * sigma:
        return None
    return UpperLimit(c, fit.forms[fit.effects.index(c)], main, float(size.value), sigma,
                      float(abs(size.value) + ZERO_Z * sigma), LIMIT_LEVEL, size.unit,
                      size.meaning, tuple(a.named), float(a.delta_bic),
                      float(a.delta_bic_tempered), float(a.tempering))


def split_upper_limits(prob, alternatives: list) -> tuple[list, tuple]:
    """``(open alternatives, upper limits)`` from the diagnosis's alternatives, each an
    ``(Alternative, its fit)``: every addition whose added effect's main size is
    consistent with zero becomes an :class:`UpperLimit` (:func:`upper_limit_of`); the
    others stay, in their order."""
    still, limits = [], []
    for a, f in alternatives:
        u = upper_limit_of(prob, a, f)
        if u is None:
            still.append((a, f))
        else:
            limits.append(u)
    return still, tuple(limits)
