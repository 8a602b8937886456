"""The next recording: what it must separate (:mod:`.propose`), the hypotheses in reach
and their predictions (:mod:`.hypotheses`), the menu of recordings
(:mod:`.menu`, with :mod:`.pooled_scans` for more scans of a recorded setting), the
separation each is expected to bring (:mod:`.expected_separation`), the choice
(:mod:`.next_measurement`) and the schedule a lab records (:mod:`.schedule`).
"""

__all__: list[str] = []
