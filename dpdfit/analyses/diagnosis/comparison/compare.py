"""What further recordings changed: a diagnosis of a campaign compared with an earlier one.

A diagnosis that cannot decide lists its ``alternatives`` and proposes a
``next_measurement`` whose ``binding`` pair it expects the recording to separate by
``expected_delta_bic``.  Once the recording is added to the campaign and the campaign
diagnosed again with that pair refitted (``diagnose(folder, refit=binding_refits(
previous["next_measurement"]))``, as ``dpdfit diagnose --compare`` does),
:func:`compare_diagnoses` says what changed (:class:`Comparison`):

* the verdict and the named effects before and after;
* each earlier alternative: settled (``rejected``, or ``named`` now) or still ``open``;
  and the alternatives that are new;
* the separation the recording achieved between the binding pair against the one
  predicted (:func:`~dpdfit.analyses.diagnosis.comparison.refits.achieved_separation`);
* whether the diagnosis now proposes another recording;
* every single effect's evidence before and after (its family's tempered delta BIC
  against the baseline, as the ranking orders them, and its gap to the best).

The pieces are computed in :mod:`~dpdfit.analyses.diagnosis.comparison.previous`; a piece
the earlier diagnosis does not have (no alternatives, no proposal, no binding pair) is
said to be missing, with the reason, not guessed.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import pandas as pd

from dpdfit.analyses.diagnosis.comparison.previous import (as_diagnosis_dict,
                                                           hypothesis_label)
from dpdfit.analyses.diagnosis.comparison.separation_outcome import (ProposalAfter,
                                                                     SeparationOutcome,
                                                                     proposal_after,
                                                                     separation)
from dpdfit.analyses.diagnosis.comparison.standing import (alternatives_standing,
                                                           evidence_rows)
from dpdfit.analyses.diagnosis.proposal.next_measurement import describe_recording
from dpdfit.core.display import Displayable
from dpdfit.errors import printable

__all__ = ["Comparison", "compare_diagnoses"]

#: the report's words for an earlier alternative's status
_STATUS_WORDS = {"named": "now named", "open": "still open", "rejected": "rejected"}


@dataclass(frozen=True, repr=False)
class Comparison(Displayable):
    """Result of :func:`compare_diagnoses` (the ``comparison`` key of ``dpdfit diagnose
    --compare --json``).

    Each piece is a typed record (:class:`~dpdfit.core.records.Record`: its attributes, or
    its JSON keys by index).
    """

    #: the campaigns the two diagnoses read
    campaign_before: str
    campaign_after: str
    #: the verdicts, and the named effects, before and after
    verdict_before: str
    verdict_after: str
    named_before: list = field(default_factory=list)
    named_after: list = field(default_factory=list)
    #: where the earlier named set stands now: ``"named"``, ``"open"`` or ``"rejected"``
    previous_named_status: str = "named"
    #: the earlier alternatives with their status now
    #: (:class:`~dpdfit.analyses.diagnosis.comparison.standing.AlternativeStanding`)
    alternatives_before: list = field(default_factory=list)
    #: the later diagnosis's alternatives that are new
    new_alternatives: list = field(default_factory=list)
    #: the separation achieved against the one predicted
    #: (:class:`~dpdfit.analyses.diagnosis.comparison.separation_outcome.SeparationOutcome`)
    separation: SeparationOutcome | None = None
    #: whether another recording is proposed
    #: (:class:`~dpdfit.analyses.diagnosis.comparison.separation_outcome.ProposalAfter`)
    next_measurement: ProposalAfter | None = None
    #: every single effect's evidence before and after
    #: (:class:`~dpdfit.analyses.diagnosis.comparison.standing.EvidenceRow`)
    evidence: list = field(default_factory=list)

    _display_title = "What the recording changed"

    @property
    def settled(self) -> list:
        """The earlier alternatives no longer in reach: rejected, or named now."""
        return [a for a in self.alternatives_before if a.status != "open"]

    @property
    def still_open(self) -> list:
        """The earlier alternatives still among the alternatives."""
        return [a for a in self.alternatives_before if a.status == "open"]

    @property
    def changed(self) -> bool:
        """The verdict or the set of named effects changed."""
        return (self.verdict_before != self.verdict_after
                or sorted(self.named_before) != sorted(self.named_after))

    def to_dict(self) -> dict:
        out = super().to_dict()
        return {**out, "changed": self.changed,
                "settled": [{"hypothesis": a.label, "how": a.status} for a in self.settled],
                "still_open": [a.label for a in self.still_open]}

    def to_frame(self) -> pd.DataFrame:
        """The evidence of every single effect before and after, one row per effect."""
        return pd.DataFrame([r.to_dict() for r in self.evidence])

    def _display_rows(self) -> list[tuple]:
        s, n = self.separation, self.next_measurement
        return [("verdict before", self.verdict_before, None, ""),
                ("verdict after", self.verdict_after, None, ""),
                ("alternatives settled", len(self.settled), None, ""),
                ("alternatives still open", len(self.still_open), None, ""),
                ("new alternatives", len(self.new_alternatives), None, ""),
                ("separation predicted", s.predicted, None, "delta BIC"),
                ("separation achieved", s.achieved, None, "delta BIC"),
                ("moved toward", s.toward_label or "neither", None, ""),
                ("predicted for that side", s.predicted_toward, None, "delta BIC"),
                ("achieved / predicted", s.ratio, None, ""),
                ("another recording", n.what or "none", None, "")]

    def _display_diagnostics(self) -> dict:
        why = self.separation.reason
        return {"warnings": [] if not why else [f"no separation to compare: {why}"]}

    def report(self) -> str:
        # the earlier diagnosis's text (a verdict, a reason) may come from elsewhere: each
        # line printable, so that none can drive the terminal
        heading = f"What the recording changed (previous diagnosis of {self.campaign_before}):"
        return "\n".join(printable(line) for line in
                         [heading, *(f"  {x}" for x in self.report_lines())])

    def report_lines(self) -> list[str]:
        """The report's lines (without the heading): verdict, alternatives, separation,
        another recording."""
        return [self._verdict_line(), *self._alternative_lines(), self._separation_line(),
                self._proposal_line()]

    def _verdict_line(self) -> str:
        named = ("" if sorted(self.named_before) == sorted(self.named_after)
                 or max(len(self.named_before), len(self.named_after)) < 2 else
                 f"   (named: {hypothesis_label(self.named_before)} -> "
                 f"{hypothesis_label(self.named_after)})")
        if not self.changed:
            return f"verdict: {self.verdict_after} (unchanged)"
        return f"verdict: {self.verdict_before} -> {self.verdict_after}{named}"

    def _alternative_lines(self) -> list[str]:
        if not self.alternatives_before:
            lines = ["the previous diagnosis had no alternatives: none to settle"]
        else:
            lines = ["alternatives before: " + ", ".join(
                f"{a.label} ({_STATUS_WORDS[a.status]})"
                for a in self.alternatives_before)]
        if self.changed and self.named_before:
            was = {"open": "is now an alternative", "rejected": "is no longer in reach",
                   "named": "is still named"}[self.previous_named_status]
            lines.append(f"the previous verdict ({hypothesis_label(self.named_before)}) "
                         f"{was}")
        if self.new_alternatives:
            lines.append("new alternatives: " + ", ".join(a.label for a in self.new_alternatives))
        return lines

    def _separation_line(self) -> str:
        s = self.separation
        if s.achieved is None:
            return f"no separation to compare: {s.reason}"
        pair = f"{s.truth} and {s.rival}"
        if s.ratio is None:
            return f"separation of {pair}: achieved {s.achieved:.3g} (delta chi2); {s.reason}"
        line = (f"separation of {pair} ({str(s.what).replace('_', ' ')}): achieved "
                f"{s.achieved:.3g} toward {s.toward_label} against {s.predicted_toward:.3g} "
                f"predicted were it true (ratio {s.ratio:.2f})")
        # the prediction holds for the recording proposed, not for another one taken instead
        if isinstance(s.settings, dict):
            try:
                line += f" for {describe_recording(s.what, s.settings)}"
            except (KeyError, TypeError, ValueError, OverflowError):
                pass                      # a hand-edited proposal: the line stands without
        return line

    def _proposal_line(self) -> str:
        n = self.next_measurement
        if not n.proposed:
            return f"no further recording proposed ({n.reason or 'none given'})"
        what = str(n.what).replace("_", " ")
        ex = n.expected_delta_bic
        ex = "" if ex is None else f", expected delta BIC {ex:.3g}"
        if n.decisive is False:
            return f"another recording proposed: {what}{ex}, not decisive ({n.reason})"
        return f"another recording proposed: {what}{ex}"


def _named(d: dict) -> list:
    return [e.get("effect") for e in d["effects"] if isinstance(e, dict)]


def compare_diagnoses(previous, current) -> Comparison:
    """What further recordings changed (module doc).

    Parameters
    ----------
    previous : dict, Diagnosis or path-like
        The earlier diagnosis: its JSON dict (``dpdfit diagnose --json``, i.e.
        :meth:`~dpdfit.analyses.diagnosis.result.Diagnosis.to_dict`), the
        :class:`~dpdfit.analyses.diagnosis.result.Diagnosis` itself, or the JSON file.
    current : Diagnosis, dict or path-like
        The diagnosis of the campaign with the new recordings, made with the earlier
        proposal's binding pair refitted
        (``refit=``:func:`~dpdfit.analyses.diagnosis.comparison.refits.binding_refits` of
        ``previous["next_measurement"]``) for the separation achieved.

    Returns
    -------
    Comparison

    Raises
    ------
    InputError
        When either is not a dpdfit diagnosis (a file: also when it is not JSON).
    """
    before, after = as_diagnosis_dict(previous), as_diagnosis_dict(current)
    alts, new, prev = alternatives_standing(before, after)
    return Comparison(
        campaign_before=str(before.get("campaign")), campaign_after=str(after.get("campaign")),
        verdict_before=before["verdict"], verdict_after=after["verdict"],
        named_before=_named(before), named_after=_named(after),
        previous_named_status=prev, alternatives_before=alts, new_alternatives=new,
        separation=separation(before, after), next_measurement=proposal_after(after),
        evidence=evidence_rows(before, after))
