"""The next recording: what it must separate (:mod:`~dpdfit.analyses.diagnosis.proposal.propose`), the hypotheses in reach
and their predictions (:mod:`~dpdfit.analyses.diagnosis.proposal.hypotheses`), the menu of recordings
(:mod:`~dpdfit.analyses.diagnosis.proposal.menu`, with :mod:`~dpdfit.analyses.diagnosis.proposal.pooled_scans` for more scans of a recorded setting), the
separation each is expected to bring (:mod:`~dpdfit.analyses.diagnosis.proposal.expected_separation`), the chosen
recording simulated (:mod:`~dpdfit.analyses.diagnosis.proposal.replicates`), the choice
(:mod:`~dpdfit.analyses.diagnosis.proposal.next_measurement`) and the schedule a lab records (:mod:`~dpdfit.analyses.diagnosis.proposal.schedule`).
"""

__all__: list[str] = []
