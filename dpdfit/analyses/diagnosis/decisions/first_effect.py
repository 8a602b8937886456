"""The first named effect: the best single effect when it is decisive and leaves an
acceptable fit or explains nearly all of the mismatch (:func:`choose_first`)."""

from __future__ import annotations

from dpdfit.analyses.diagnosis.evidence.ranking import decisive
from dpdfit.analyses.diagnosis.evidence.thresholds import ALPHA_FIT

__all__ = ['choose_first']


def choose_first(ranking: list, n_tests: int, sides: set | None = None):
    """The first named effect when there is evidence of a mismatch: ``(name or None,
    approximate)``.

    The best single effect if it is decisive (:func:`decisive`, Bonferroni over the
    ``n_tests`` effects tried) *and* leaves an acceptable fit (chi2 p-value >=
    ``ALPHA_FIT``) or explains ``EXPLAINED_FRACTION`` of the baseline's excess chi2
    (then ``approximate``: its form does not describe everything; further effects may);
    a decisive effect that explains less may still be completed by further effects
    (the caller decides, :func:`dpdfit.analyses.diagnosis.diagnose.diagnose`); None when
    no single effect is decisive.
    """
    singles = [r for r in ranking if "+" not in r["effect"]
               and (sides is None or r["side"] in sides)]
    if not singles or not decisive(singles[0], n_tests):
        return None, False
    best = singles[0]
    return best["effect"], best["p_fit"] < ALPHA_FIT
