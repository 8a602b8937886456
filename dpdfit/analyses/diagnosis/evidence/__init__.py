"""What the fits say: where the baseline fails (:mod:`~dpdfit.analyses.diagnosis.evidence.mismatches`, searching
:mod:`~dpdfit.analyses.diagnosis.evidence.deviations`), each hypothesis's evidence against the one it extends
(:mod:`~dpdfit.analyses.diagnosis.evidence.ranking`), judged against the misfit the forms leave (:mod:`~dpdfit.analyses.diagnosis.evidence.tempering`) and per
family of forms (:mod:`~dpdfit.analyses.diagnosis.evidence.families`), the errors that include the form
(:mod:`~dpdfit.analyses.diagnosis.evidence.form_errors`), the cost in Bell fidelity (:mod:`~dpdfit.analyses.diagnosis.evidence.fidelity_cost`), a smooth
generic discrepancy where nothing in the catalog fits (:mod:`~dpdfit.analyses.diagnosis.evidence.generic_discrepancy`), and
the thresholds every decision uses (:mod:`~dpdfit.analyses.diagnosis.evidence.thresholds`).
"""

__all__: list[str] = []
