"""The separation further recordings achieved between the earlier proposal's binding
pair, against the one it predicted (:func:`separation`), and whether the later diagnosis
proposes another recording (:func:`proposal_after`)."""

from __future__ import annotations

from dataclasses import dataclass

from dpdfit.analyses.diagnosis.comparison.previous import (hypothesis_label, json_number,
                                                           named_in, unknown_in_binding)
from dpdfit.analyses.diagnosis.comparison.refits import (achieved_separation, binding_chi2,
                                                         binding_refits, refitted_chi2,
                                                         separation_direction)
from dpdfit.core.records import Record

__all__ = ["SeparationOutcome", "ProposalAfter", "separation", "proposal_after"]


@dataclass(frozen=True)
class SeparationOutcome(Record):
    """The separation further recordings achieved between the earlier proposal's binding
    pair, against the one predicted (None where a value is missing, with the ``reason``)."""

    #: the recording proposed and its settings
    what: str | None
    settings: dict | None
    #: the binding pair's labels: the hypothesis whose prediction binds, and its rival
    truth: str | None
    rival: str | None
    #: the proposal's expected delta BIC, and the one expected were each true
    predicted: float | None
    predicted_if_truth: float | None
    predicted_if_rival: float | None
    #: the pair's chi2 in the proposal and refitted now, ``{"truth", "rival"}``
    chi2_before: dict | None
    chi2_after: dict | None
    #: the separation achieved (delta chi2) and achieved / predicted for the side the
    #: recording moved toward (``predicted_toward``)
    achieved: float | None
    ratio: float | None
    #: why a value is None (None when all are there)
    reason: str | None = None
    #: the side the recording moved toward (``"truth"`` or ``"rival"``, None when it did
    #: not move), its label, and the separation predicted were that side true
    toward: str | None = None
    toward_label: str | None = None
    predicted_toward: float | None = None


@dataclass(frozen=True)
class ProposalAfter(Record):
    """Whether the later diagnosis proposes another recording (its settings are that
    diagnosis's own proposal)."""

    proposed: bool
    what: str | None
    decisive: bool | None
    expected_delta_bic: float | None
    #: why none is proposed, or why it does not decide
    reason: str | None


def _no_separation(before: dict, nxt) -> str | None:
    """Why the earlier diagnosis leaves no separation to compare (None: it does not)."""
    if not isinstance(nxt, dict):
        alts = "" if before.get("alternatives") else " had no alternatives and"
        return f"the previous diagnosis{alts} proposed no recording"
    if not nxt.get("what"):
        return (f"the previous diagnosis proposed no recording: "
                f"{nxt.get('reason') or 'no reason given'}")
    if binding_refits(nxt) is None:
        return "the previous proposal names no binding pair to refit"
    if binding_chi2(nxt) is None:
        return "the previous proposal does not carry its binding pair's chi2"
    unknown = unknown_in_binding(nxt)
    if unknown:
        return (f"the previous proposal's pair names what this catalog does not have "
                f"({', '.join(unknown)})")
    return None


def separation(before: dict, after: dict) -> SeparationOutcome:
    """The separation between the earlier proposal's binding pair that the recordings
    achieved (:func:`~dpdfit.analyses.diagnosis.comparison.refits.achieved_separation` of the pair's
    chi2 in the proposal and refitted by the later diagnosis) against the one predicted:
    ``what``, ``truth``, ``rival`` (labels), ``predicted`` (the proposal's
    ``expected_delta_bic``), ``predicted_if_truth`` / ``predicted_if_rival`` (the
    separation expected were that one true), ``chi2_before`` / ``chi2_after``
    (``{"truth", "rival"}``), ``achieved``, ``toward`` / ``toward_label`` (the side the
    recording moved toward), ``predicted_toward`` (the separation predicted were that
    side true), ``ratio`` (achieved / ``predicted_toward``) and ``reason`` (why a value
    is None; None when all are there)."""
    nxt = before.get("next_measurement")
    out = {"what": None, "settings": None, "truth": None, "rival": None, "predicted": None,
           "predicted_if_truth": None, "predicted_if_rival": None, "chi2_before": None,
           "chi2_after": None, "achieved": None, "ratio": None}
    why = _no_separation(before, nxt)
    if why is not None:
        return SeparationOutcome(**{**out, "what": (nxt or {}).get("what")
                                    if isinstance(nxt, dict) else None, "reason": why})
    b = nxt["binding"]
    out.update(what=nxt["what"], settings=nxt.get("settings"),
               predicted=json_number(nxt.get("expected_delta_bic")),
               truth=hypothesis_label(b["truth"].get("effects")),
               rival=hypothesis_label(b["rival"].get("effects")),
               predicted_if_truth=json_number(b["truth"].get("expected_delta_bic")),
               predicted_if_rival=json_number(b["rival"].get("expected_delta_bic")),
               chi2_before=binding_chi2(nxt),
               chi2_after=refitted_chi2(nxt, after.get("refits")))
    if out["chi2_after"] is None:
        return SeparationOutcome(**out, reason="this diagnosis did not refit the previous "
                                               "proposal's binding pair (diagnose(..., "
                                               "refit=binding_refits(previous "
                                               "next_measurement)))")
    out["achieved"] = achieved_separation(out["chi2_before"], out["chi2_after"])
    side = separation_direction(out["chi2_before"], out["chi2_after"])
    toward = {"toward": side, "toward_label": out.get(side) if side else None}
    if not out["predicted"] or out["predicted"] <= 0 or out["achieved"] is None:
        return SeparationOutcome(**out, **toward, reason="the previous proposal predicted no "
                                                        "separation to compare with")
    if side is None:
        return SeparationOutcome(**out, **toward, reason="the recording did not move the "
                                                        "pair apart")
    # a recording that moved toward the rival is measured against what was predicted were
    # the rival true, not against the truth's figure (the ratio would be about neither)
    p = (out["predicted_if_truth"] or out["predicted"]) if side == "truth" \
        else out["predicted_if_rival"]
    if not p or p <= 0:
        return SeparationOutcome(**out, **toward, reason=f"the recording moved toward "
                                 f"{toward['toward_label']}, for which the previous proposal "
                                 "predicted no separation")
    out["ratio"] = out["achieved"] / p
    return SeparationOutcome(**out, **toward, predicted_toward=p, reason=None)


def proposal_after(after: dict) -> ProposalAfter:
    """Whether the later diagnosis proposes another recording: ``proposed``, ``what``,
    ``decisive``, ``expected_delta_bic`` and ``reason`` (its settings are the diagnosis's
    own ``next_measurement``)."""
    nxt = after.get("next_measurement")
    if not isinstance(nxt, dict):
        why = ("no effect is named" if not named_in(after) else "none given"
               if after.get("alternatives") else "no alternatives and no poorly "
                                                 "constrained size")
        return ProposalAfter(False, None, None, None, why)
    return ProposalAfter(bool(nxt.get("what")), nxt.get("what"),
                         nxt.get("decisive") if nxt.get("what") else None,
                         json_number(nxt.get("expected_delta_bic")), nxt.get("reason"))
