"""Where each hypothesis stands after further recordings: every earlier alternative
(``named``, ``open`` or ``rejected``) and every single effect's evidence before and after
(:func:`alternatives_standing`, :func:`evidence_rows`)."""

from __future__ import annotations

from dataclasses import dataclass

from dpdfit.analyses.diagnosis.comparison.previous import (hypothesis_label, json_number,
                                                           named_in)
from dpdfit.core.records import Record

__all__ = ["AlternativeStanding", "EvidenceRow", "EVIDENCE_KEYS", "alternatives_standing",
           "evidence_rows"]


@dataclass(frozen=True)
class AlternativeStanding(Record):
    """An alternative of either diagnosis, and for an earlier one where it stands now."""

    #: the candidate effect
    effect: str | None
    #: the complete set of effects it stands for
    named: tuple
    #: the named effect it would replace (None: an addition)
    replaces: str | None
    #: the hypothesis as one label, e.g. ``"stale_calibration + dephasing"``
    label: str
    #: its delta BIC against the named hypothesis of its diagnosis, raw and tempered
    delta_bic: float | None
    delta_bic_tempered: float | None
    #: an earlier alternative's status now: ``"named"``, ``"open"`` or ``"rejected"``
    #: (None for a new alternative)
    status: str | None = None
    #: an open one's tempered delta BIC now (None otherwise)
    delta_bic_tempered_after: float | None = None

    def to_dict(self) -> dict:
        """The JSON's entry; ``status`` and ``delta_bic_tempered_after`` for an earlier
        alternative only."""
        out = {"effect": self.effect, "named": list(self.named), "replaces": self.replaces,
               "label": self.label, "delta_bic": self.delta_bic,
               "delta_bic_tempered": self.delta_bic_tempered}
        if self.status is not None:
            out.update(status=self.status, delta_bic_tempered_after=self.delta_bic_tempered_after)
        return out


@dataclass(frozen=True)
class EvidenceRow(Record):
    """One single effect's evidence before and after (None where that diagnosis did not
    rank it): its ``delta_bic`` (raw, against the baseline), ``evidence`` (the first of
    :data:`EVIDENCE_KEYS` its ranking entry has), ``gap`` (``evidence`` minus the best's:
    0 for the best, > 0 worse) and ``role`` (``"named"``, ``"alternative"`` or None)."""

    effect: str
    delta_bic_before: float | None
    evidence_before: float | None
    gap_before: float | None
    role_before: str | None
    delta_bic_after: float | None
    evidence_after: float | None
    gap_after: float | None
    role_after: str | None


def _key(a: dict) -> tuple:
    return tuple(sorted(a.get("named") or [a.get("effect")]))


def _alt(a: dict, **more) -> AlternativeStanding:
    named = a.get("named") or [a.get("effect")]
    return AlternativeStanding(a.get("effect"), tuple(named), a.get("replaces"),
                               hypothesis_label(named), a.get("delta_bic"),
                               a.get("delta_bic_tempered"), **more)


def _standing(a: dict, named_after: list, alts_after: list) -> tuple[str, dict | None]:
    """``("named" | "open" | "rejected", the later alternative it matches or None)``: the
    complete set of effects first, then the effect itself."""
    key = _key(a)
    if key == tuple(sorted(named_after)):
        return "named", None
    same = next((b for b in alts_after if _key(b) == key), None)
    if same is not None:
        return "open", same
    if a.get("effect") in named_after:
        return "named", None
    same = next((b for b in alts_after if b.get("effect") == a.get("effect")), None)
    return ("open", same) if same is not None else ("rejected", None)


def alternatives_standing(before: dict, after: dict) -> tuple[list, list, str]:
    """``(earlier alternatives with their status now, new alternatives, status of the
    earlier named set)``.  An earlier alternative is ``"named"`` when the later diagnosis
    names it, ``"open"`` while it is still among the alternatives (with its evidence now,
    ``delta_bic_tempered_after``), ``"rejected"`` otherwise; the earlier named set is
    ``"named"``, ``"open"`` (now an alternative) or ``"rejected"`` the same way."""
    named_after = named_in(after)
    alts_after = [a for a in after.get("alternatives") or [] if isinstance(a, dict)]
    out, matched = [], []
    for a in before.get("alternatives") or []:
        if not isinstance(a, dict):
            continue
        status, now = _standing(a, named_after, alts_after)
        matched.append(now)
        out.append(_alt(a, status=status, delta_bic_tempered_after=(
            None if now is None else now.get("delta_bic_tempered"))))
    named_before = named_in(before)
    # new: neither an earlier alternative still open nor the earlier named set
    new = [_alt(a) for a in alts_after if not any(a is m for m in matched)
           and _key(a) != tuple(sorted(named_before))]
    prev = (_standing({"effect": named_before[0] if named_before else None,
                       "named": named_before}, named_after, alts_after)[0]
            if named_before else "rejected")
    return out, new, prev


#: the evidence of a ranking entry, first found: its family's tempered delta BIC (what the
#: ranking orders by; each effect's own tempering differs, so its tempered delta BIC
#: against the baseline does not compare across effects), else its own, else the raw one
EVIDENCE_KEYS = ("family_delta_bic_tempered", "delta_bic_tempered", "delta_bic")


def _evidence(entry: dict):
    return next((v for v in map(json_number, (entry.get(k) for k in EVIDENCE_KEYS))
                 if v is not None), None)


def _role(effect: str, d: dict) -> str | None:
    if effect in named_in(d):
        return "named"
    alts = [a for a in d.get("alternatives") or [] if isinstance(a, dict)]
    return "alternative" if any(a.get("effect") == effect for a in alts) else None


def evidence_rows(before: dict, after: dict) -> list:
    """One :class:`EvidenceRow` per single effect of either ranking, ordered as the later
    ranking, then the effects only the earlier one ranked."""
    rank = {}
    for when, d in (("before", before), ("after", after)):
        entries = {r["effect"]: r for r in d.get("ranking") or []
                   if isinstance(r, dict) and r.get("effect")}
        ev = {e: _evidence(r) for e, r in entries.items()}
        best = min([v for v in ev.values() if v is not None], default=None)
        rank[when] = {e: {"delta_bic": r.get("delta_bic"), "evidence": ev[e],
                          "gap": None if ev[e] is None or best is None else ev[e] - best,
                          "role": _role(e, d)} for e, r in entries.items()}
    order = list(dict.fromkeys([*rank["after"], *rank["before"]]))
    return [EvidenceRow(e, **{f"{k}_{w}": (rank[w].get(e) or {}).get(k)
                              for w in ("before", "after")
                              for k in ("delta_bic", "evidence", "gap", "role")})
            for e in order]
