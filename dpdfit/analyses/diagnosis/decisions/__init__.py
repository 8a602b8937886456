"""The verdict from the evidence: the first named effect (:mod:`~dpdfit.analyses.diagnosis.decisions.first_effect`), further
effects added to it (:mod:`~dpdfit.analyses.diagnosis.decisions.additions`), complete explanations from every first effect
in reach (:mod:`~dpdfit.analyses.diagnosis.decisions.explanations`), the alternatives the recordings do not separate
(:mod:`~dpdfit.analyses.diagnosis.decisions.alternatives`), the additions they do not see, bounded
(:mod:`~dpdfit.analyses.diagnosis.decisions.upper_limits`), and the named effects as reported (:mod:`~dpdfit.analyses.diagnosis.decisions.named_effects`).
"""

__all__: list[str] = []
