"""What further recordings changed: a diagnosis compared with an earlier one of the same
campaign (:mod:`.compare`, :func:`~.compare.compare_diagnoses`): the earlier JSON
(:mod:`.previous`), where each hypothesis stands now (:mod:`.standing`), the separation
achieved against the one predicted (:mod:`.separation_outcome`, from the refits of
:mod:`.refits`).
"""

from dpdfit.analyses.diagnosis.comparison.compare import Comparison, compare_diagnoses

__all__ = ["Comparison", "compare_diagnoses"]
