"""The evidence of one hypothesis against the one it extends: the ranking entry
(:func:`rank_entry`: delta BIC, likelihood-ratio test, both raw and tempered by the misfit
the forms leave, :mod:`~dpdfit.analyses.diagnosis.evidence.tempering`), whether it is
decisive (:func:`decisive`) and how much of the baseline's excess chi2 it explains
(:func:`explained_fraction`)."""

from __future__ import annotations

from scipy.stats import chi2 as chi2_dist

from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.analyses.diagnosis.evidence.tempering import tempered_gap
from dpdfit.analyses.diagnosis.evidence.thresholds import ALPHA, BIC_DECISIVE
from dpdfit.analyses.diagnosis.fitting.fit_result import FitResult

__all__ = ['explained_fraction', 'rank_entry', 'decisive']


def explained_fraction(base: FitResult, f: FitResult) -> float | None:
    """Fraction of the baseline's excess chi2 (over its dof) that ``f`` removes;
    None when the baseline has no excess."""
    excess = base.chi2 - base.dof
    return float((base.chi2 - f.chi2) / excess) if excess > 0 else None


def rank_entry(base: FitResult, f: FitResult, cost: tuple | None = None) -> dict:
    """The ranking entry of hypothesis ``f`` against ``base`` (the baseline, or for an
    added effect the model it was added to)."""
    dchi = base.chi2 - f.chi2
    k = f.n_par - base.n_par
    # the evidence judged against the misfit the forms leave (dpdfit...tempering)
    _, gap_t, tau = tempered_gap(base, f)
    single = len(f.effects) == 1
    params = f.params_of(f.effect) if single else dict(f.params)
    errs = f.errors_of(f.effect) if single else dict(f.params_err)
    sizes = {name: {k_: s.to_dict() for k_, s in sz.items()} for name, sz in f.sizes.items()}
    return {"effect": f.effect, **({"variant": f.variant} if f.variant else {}),
            "side": "+".join(sorted({EFFECTS[e].side for e in f.effects})),
            **({"impact": abs(cost[0]), "fidelity_cost": cost[0],
                "fidelity_cost_err": cost[1]} if cost is not None else {}),
            "explained_fraction": explained_fraction(base, f),
            "delta_bic": float(f.bic - base.bic),
            "p_value": float(chi2_dist.sf(max(dchi, 0.0), max(k, 1))), "delta_chi2": float(dchi),
            "tempering": tau, "delta_bic_tempered": -gap_t,
            "p_value_tempered": float(chi2_dist.sf(max(dchi, 0.0) / tau, max(k, 1))),
            "params": params, "params_err": errs,
            "sizes": sizes[f.effect] if single else sizes,
            "chi2": f.chi2, "dof": f.dof, "p_fit": f.p_fit}


def decisive(entry: dict, n_tests: int) -> bool:
    """A hypothesis is decisive against the one it extends: its *tempered* delta BIC below
    ``-BIC_DECISIVE`` and its tempered likelihood-ratio p-value, Bonferroni-corrected
    over ``n_tests``, below ALPHA (the chi2 difference divided by the dispersion of the
    evidence, :mod:`dpdfit.analyses.diagnosis.evidence.tempering`).  Entries that carry their
    family's evidence (``family_delta_bic_tempered``, ``family_p_value_tempered``:
    :mod:`dpdfit.analyses.diagnosis.evidence.families`) are judged on it, a family being the
    unit of every decision; entries without tempering on the raw values."""
    dbic = entry.get("family_delta_bic_tempered",
                     entry.get("delta_bic_tempered", entry["delta_bic"]))
    p = entry.get("family_p_value_tempered", entry.get("p_value_tempered", entry["p_value"]))
    return dbic < -BIC_DECISIVE and p * n_tests < ALPHA
