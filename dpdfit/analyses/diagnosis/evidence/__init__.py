"""What the fits say: where the baseline fails (:mod:`.mismatches`, searching
:mod:`.deviations`), each hypothesis's evidence against the one it extends
(:mod:`.ranking`), judged against the misfit the forms leave (:mod:`.tempering`) and per
family of forms (:mod:`.families`), the errors that include the form
(:mod:`.form_errors`), the cost in Bell fidelity (:mod:`.fidelity_cost`), a smooth
generic discrepancy where nothing in the catalog fits (:mod:`.generic_discrepancy`), and
the thresholds every decision uses (:mod:`.thresholds`).
"""

__all__: list[str] = []
