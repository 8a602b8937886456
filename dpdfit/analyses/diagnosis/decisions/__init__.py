"""The verdict from the evidence: the first named effect (:mod:`.first_effect`), further
effects added to it (:mod:`.additions`), complete explanations from every first effect
in reach (:mod:`.explanations`), the alternatives the recordings do not separate
(:mod:`.alternatives`) and the named effects as reported (:mod:`.named_effects`).
"""

__all__: list[str] = []
