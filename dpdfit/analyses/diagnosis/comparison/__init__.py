"""What further recordings changed: a diagnosis compared with an earlier one of the same
campaign (:mod:`~dpdfit.analyses.diagnosis.comparison.compare`, :func:`~dpdfit.analyses.diagnosis.comparison.compare.compare_diagnoses`): the earlier JSON
(:mod:`~dpdfit.analyses.diagnosis.comparison.previous`), where each hypothesis stands now (:mod:`~dpdfit.analyses.diagnosis.comparison.standing`), the separation
achieved against the one predicted (:mod:`~dpdfit.analyses.diagnosis.comparison.separation_outcome`, from the refits of
:mod:`~dpdfit.analyses.diagnosis.comparison.refits`).
"""

from dpdfit.analyses.diagnosis.comparison.compare import Comparison, compare_diagnoses

__all__ = ["Comparison", "compare_diagnoses"]
