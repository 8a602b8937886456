"""A cause is a family of forms: the evidence the diagnosis weighs is a family's.

An effect of the catalog (:mod:`~dpdfit.analyses.diagnosis.effects`) is a cause
-- a drifted AOM, a nonlinear detector, extra dephasing -- and its forms are
the shapes its physics allows.  A laboratory's physics is none of them
exactly, so no decision may hinge on which form happens to resemble it
best.  This module states the evidence per family:

* **Form gains.**  Each form ``f`` fitted against a reference fit ``R`` (the
  baseline, or the named effects before an addition) has the tempered gain
  ``g_f = (chi2_R - chi2_f) / tau_f - (k_f - k_R) ln n``: minus its tempered
  delta BIC (:func:`~dpdfit.analyses.diagnosis.evidence.tempering.tempered_gap`).
* **Family evidence.**  The family's gain is the evidence-weighted average of
  its forms with equal prior weight, ``G = 2 ln((1/F) sum_f exp(g_f / 2))``
  (``F`` forms): a Bayesian model average over the family in BIC units.  It
  lies between the best form's gain minus ``2 ln F`` (one form carries it:
  the family pays for having chosen it among ``F``) and the best form's gain
  (every form explains the recordings as well).  Its likelihood-ratio
  p-value is the best form's, Bonferroni-corrected over the forms.
* **Within the noise.**  Whether the recordings separate two hypotheses is
  judged on their chi2 difference ``D`` against its own scatter, not on the
  parameters they count: with ``d`` the per-point difference of their
  standardised residuals and ``C`` the residuals' covariance
  (:func:`~dpdfit.analyses.diagnosis.evidence.tempering.hac_quadratic`),
  ``var D = 4 d^T C d`` and ``z = D / sqrt(var D)``: a non-nested
  likelihood-ratio statistic (Vuong 1989) with the misfit's own covariance.
  A family whose form is within ``NOISE_Z`` of the verdict is an alternative,
  whatever its parameter count.
* **Nesting.**  Form ``a`` is nested in ``b`` when every parameter ``a`` frees
  ``b`` frees too and every parameter ``b`` fixes ``a`` fixes to the same
  value; the *maximal* forms of a family (nested in no other) are those an
  addition must be needed against (:func:`maximal_forms`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.special import logsumexp
from scipy.stats import chi2 as chi2_dist

from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.analyses.diagnosis.evidence.tempering import (hac_quadratic, series_pairs,
                                                          tempered_gap)

__all__ = ["FamilyEvidence", "family_evidence", "form_gain", "chi2_gap_z", "nested",
           "maximal_forms", "shared_observables"]

def form_gain(ref, fit) -> tuple[float, float, float]:
    """``(raw, tempered, tau)``: minus the delta BIC of ``fit`` against ``ref`` (positive
    favours ``fit``), raw and with the chi2 difference tempered by the dispersion of the
    evidence ``tau``."""
    raw, tempered, tau = tempered_gap(ref, fit)
    return float(raw), float(tempered), float(tau)


def _logmeanexp2(g: np.ndarray) -> float:
    """``2 ln mean exp(g / 2)`` (stable)."""
    return float(2.0 * (logsumexp(0.5 * np.asarray(g, float)) - np.log(len(g))))


@dataclass(frozen=True)
class FamilyEvidence:
    """The evidence of one family against a reference fit (module doc).

    Attributes
    ----------
    family : str
        The effect's name.
    gain, gain_raw : float
        The family's gain ``G`` (tempered, and raw), in BIC units; minus them are the
        family's delta BIC.
    p_value : float
        The best form's tempered likelihood-ratio p-value, Bonferroni over the forms.
    best : str
        The form with the largest tempered gain.
    forms : dict
        ``{form: (raw gain, tempered gain, tau)}``.
    """

    family: str
    gain: float
    gain_raw: float
    p_value: float
    best: str
    forms: dict = field(default_factory=dict)

    def decisive(self, n_tests: int, threshold: float, alpha: float) -> bool:
        """The family is decisive: tempered gain above ``threshold`` and its p-value,
        Bonferroni over ``n_tests`` families, below ``alpha``."""
        return self.gain > threshold and self.p_value * max(n_tests, 1) < alpha

    def to_dict(self) -> dict:
        """JSON-ready: ``family_delta_bic`` (raw), ``family_delta_bic_tempered``,
        ``family_p_value_tempered``, ``best_form`` and per form its tempered delta BIC."""
        return {"family_delta_bic": -self.gain_raw, "family_delta_bic_tempered": -self.gain,
                "family_p_value_tempered": self.p_value, "best_form": self.best,
                "forms_delta_bic_tempered": {f: -v[1] for f, v in self.forms.items()}}


def _lrt_p(ref, fit, tau: float) -> float:
    """Tempered likelihood-ratio p-value of ``fit`` against ``ref``."""
    dchi = max(ref.chi2 - fit.chi2, 0.0) / max(tau, 1.0)
    k = max(fit.n_par - ref.n_par, 1)
    return float(chi2_dist.sf(dchi, k))


def family_evidence(name: str, ref, fits: dict, n_forms: int | None = None
                    ) -> FamilyEvidence:
    """The evidence of family ``name`` against ``ref`` from its forms' fits ``fits``
    (``{form: FitResult}``).  ``n_forms``: the number of forms the family has when only
    some of them were fitted (e.g. an addition fitted in its best form): the forms not
    fitted count as giving no evidence, so the result is the lower bound
    ``2 ln((1/F) sum_fitted exp(g_f / 2))``."""
    if not fits:
        raise ValueError(f"family {name}: no form fitted")
    gains = {f: form_gain(ref, fit) for f, fit in fits.items()}
    F = max(int(n_forms or len(fits)), len(fits))
    t = np.array([g[1] for g in gains.values()])
    r = np.array([g[0] for g in gains.values()])
    G = _logmeanexp2(np.concatenate([t, np.full(F - len(t), -np.inf)]))
    G_raw = _logmeanexp2(np.concatenate([r, np.full(F - len(r), -np.inf)]))
    best = max(gains, key=lambda f: gains[f][1])
    p = min(1.0, min(_lrt_p(ref, fits[f], gains[f][2]) for f in fits) * F)
    return FamilyEvidence(name, G, G_raw, p, best, gains)


def _chi2_of(f, prefixes) -> float:
    if prefixes is None:
        return float(f.chi2)
    return float(sum(v for k, v in f.chi2_by_observable.items() if k.startswith(prefixes)))


def chi2_gap_z(a, b, prefixes: tuple | None = None) -> float:
    """How many standard deviations of its own scatter the chi2 difference between fits
    ``a`` and ``b`` is (module doc): ``(chi2_worse - chi2_better) / sqrt(4 d^T C d)``,
    ``C`` from the better fit's residuals; ``inf`` when the fits carry no residual
    blocks but differ, 0 when they do not differ.  ``prefixes``: only the observables
    whose keys start so (e.g. ``("tones:", "runs:")``, the tone side) count."""
    D = _chi2_of(b, prefixes) - _chi2_of(a, prefixes)
    better, worse = (a, b) if D >= 0 else (b, a)
    D = abs(D)
    blocks_b = dict(getattr(better, "blocks", ()) or ())
    blocks_w = dict(getattr(worse, "blocks", ()) or ())
    var = 0.0
    for key, zb in blocks_b.items():
        zw = blocks_w.get(key)
        if zw is None or (prefixes is not None and not key.startswith(prefixes)):
            continue
        for sb, sw in series_pairs(zb, zw):
            q, _ = hac_quadratic(sw - sb, sb)
            var += 4.0 * q
    if D <= 0:
        return 0.0
    if var <= 0 or not np.isfinite(var):
        return float("inf")
    return float(D / np.sqrt(var))


def nested(a, b) -> bool:
    """Whether form ``a`` is nested in form ``b`` of the same family (module doc)."""
    if a.name == b.name:
        return True
    if not set(a.free) <= set(b.free):
        return False
    for k, v in b.fixed.items():
        if k in a.free or a.fixed.get(k, v) != v:
            return False
    return set(b.replaces) <= set(a.replaces)


def maximal_forms(forms) -> list:
    """The forms of ``forms`` nested in no other one, in their order."""
    forms = list(forms)
    return [f for f in forms
            if not any(g is not f and nested(f, g) and not nested(g, f) for g in forms)]


#: the observables of each side, by key prefix
_SIDE_PREFIXES = {"tones": ("tones:", "runs:"), "gates": ("gates:", "time_scan:")}


def shared_observables(a, b) -> tuple | None:
    """The observables on which two single-effect fits can be compared: both sides when
    both were predicted there alike; the tone side when both act on the tones and only
    one had its field carried to the gates (the other's gates are the baseline's)."""
    sides = {getattr(EFFECTS.get(e), "side", None) for e in a.effects + b.effects}
    if sides == {"tones"}:
        return _SIDE_PREFIXES["tones"]
    return None
