"""Model adequacy of a least-squares fit: is its reduced chi-square plausible?

With absolute uncertainties (dpdfit's error convention: errors are absolute
when sigmas are given, never silently rescaled) a correct model gives
``chi2 ~ chi2(dof)``.  A fit whose reduced chi-square lies outside the
central 99 % range of ``chi2(dof)/dof``,

    [chi2.ppf(0.005, dof)/dof, chi2.ppf(0.995, dof)/dof],

is flagged ``model_adequate = False`` (a correct model is flagged 1 % of the
time).  Beside the absolute errors the result then offers *Birge-scaled*
errors, ``error * sqrt(reduced chi2)`` (the Birge ratio), for a reader who
wants to absorb unexplained scatter; the primary errors are never changed.
(Below the range -- sigmas too large -- the factor is < 1 and the reports do
not list Birge-scaled errors, though ``birge`` still computes them.)

When sigma was estimated from the residuals (``sigma_source ==
"residuals"``) the reduced chi-square is 1 by construction (or not
dimensionless), the test does not apply: ``model_adequate`` is ``None`` and
the Birge factor is ``None`` (the errors are already scaled by the scatter).
"""

from __future__ import annotations

import math

from scipy import stats

__all__ = ["ADEQUACY_LEVEL", "redchi_range", "ModelAdequacy"]

#: central probability of the reduced chi-square range a correct model stays in
ADEQUACY_LEVEL = 0.99


def redchi_range(dof: int, level: float = ADEQUACY_LEVEL) -> tuple[float, float]:
    """Central ``level`` range of ``chi2(dof)/dof``."""
    tail = (1 - level) / 2
    return (float(stats.chi2.ppf(tail, dof) / dof), float(stats.chi2.ppf(1 - tail, dof) / dof))


class ModelAdequacy:
    """Mixin for fit results with ``chi2``, ``dof``, a reduced chi-square
    (``reduced_chi2`` or ``redchi``) and optionally ``sigma_source``.

    ``_adequacy_model`` names the model in the report line.
    """

    _adequacy_model: str = "the model"

    def _redchi_value(self) -> float:
        red = getattr(self, "reduced_chi2", None)
        return float(getattr(self, "redchi", math.nan) if red is None else red)

    @property
    def adequacy_testable(self) -> bool:
        """Absolute sigmas, ``dof > 0`` and a finite chi-square."""
        return (getattr(self, "sigma_source", "given") == "given" and int(self.dof) > 0
                and math.isfinite(float(self.chi2)))

    @property
    def redchi_range_99(self) -> tuple[float, float] | None:
        """Central 99 % range of the reduced chi-square for ``dof`` (None if not testable)."""
        return redchi_range(int(self.dof)) if self.adequacy_testable else None

    @property
    def model_adequate(self) -> bool | None:
        """Reduced chi-square inside :attr:`redchi_range_99` (None if not testable)."""
        rng = self.redchi_range_99
        return None if rng is None else bool(rng[0] <= self._redchi_value() <= rng[1])

    @property
    def chi2_p_value(self) -> float | None:
        """Upper-tail probability ``P(chi2(dof) >= chi2)`` (None if not testable)."""
        return float(stats.chi2.sf(self.chi2, int(self.dof))) if self.adequacy_testable else None

    @property
    def birge_factor(self) -> float | None:
        """``sqrt(reduced chi2)`` (None if not testable)."""
        return math.sqrt(self._redchi_value()) if self.adequacy_testable else None

    def birge(self, error):
        """``error`` scaled by the Birge factor (unchanged when not testable)."""
        f = self.birge_factor
        return error if f is None else error * f

    @property
    def stderr_birge(self):
        """``stderr`` (of a result that has one) times the Birge factor; ``stderr``
        itself stays the absolute error."""
        return self.birge(self.stderr)

    def adequacy_dict(self) -> dict:
        """The adequacy keys of ``to_dict()``."""
        rng = self.redchi_range_99
        return {"model_adequate": self.model_adequate,
                "redchi_range_99": None if rng is None else list(rng),
                "birge_factor": self.birge_factor, "chi2_p_value": self.chi2_p_value}

    def adequacy_lines(self, errors: dict | None = None) -> list[str]:
        """Report lines: the 99 % check and, when it fails, the Birge-scaled ``errors``
        (``{name: (error, unit)}``) beside the absolute ones."""
        rng = self.redchi_range_99
        if rng is None:
            return []
        red = self._redchi_value()
        if self.model_adequate:
            return [f"    adequacy    : reduced chi2 {red:.3g} within its 99 % range "
                    f"[{rng[0]:.3g}, {rng[1]:.3g}] for dof {int(self.dof)}"]
        what = (f"{self._adequacy_model} does not describe the data (or the sigmas are too "
                "small)" if red > rng[1] else "the given sigmas look too large (or the "
                "points are not independent)")
        lines = [f"    ** {what}: reduced chi2 {red:.3g} outside its 99 % range "
                 f"[{rng[0]:.3g}, {rng[1]:.3g}] for dof {int(self.dof)} "
                 f"(p = {self.chi2_p_value:.2g}) **"]
        if red < rng[0]:          # a Birge scaling would shrink the errors: not offered here
            return lines
        lines += [f"    Birge-scaled errors (x sqrt(reduced chi2) = {self.birge_factor:.3g}; "
                  "the errors above stay absolute):"]
        for name, (err, unit) in (errors or {}).items():
            lines.append(f"      {name:<10s}: +/- {self.birge(err):.4g} {unit}".rstrip())
        return lines
