"""Where each hypothesis stands after further recordings: every earlier alternative
(``named``, ``open`` or ``rejected``) and every single effect's evidence before and after
(:func:`alternatives_standing`, :func:`evidence_rows`)."""

from __future__ import annotations

from dpdfit.analyses.diagnosis.comparison.previous import hypothesis_label, named_in
from dpdfit.analyses.diagnosis.comparison.previous import json_number

__all__ = ['EVIDENCE_KEYS', 'alternatives_standing', 'evidence_rows']


def _key(a: dict) -> tuple:
    return tuple(sorted(a.get("named") or [a.get("effect")]))


def _alt(a: dict, **more) -> dict:
    return {"effect": a.get("effect"), "named": list(a.get("named") or [a.get("effect")]),
            "replaces": a.get("replaces"), "label": hypothesis_label(a.get("named")
                                                                     or [a.get("effect")]),
            "delta_bic": a.get("delta_bic"), "delta_bic_tempered": a.get("delta_bic_tempered"),
            **more}


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
    """One row per single effect of either ranking: ``effect``, and ``_before`` /
    ``_after`` its ``delta_bic`` (raw, against the baseline), ``evidence`` (the first of
    :data:`EVIDENCE_KEYS` the entry has), ``gap`` (``evidence`` minus the best's:
    0 for the best, > 0 worse) and ``role`` (``"named"``, ``"alternative"`` or None);
    None where that diagnosis did not rank the effect.  Ordered as the later ranking,
    then the effects only the earlier one ranked."""
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
    return [{"effect": e, **{f"{k}_{w}": (rank[w].get(e) or {}).get(k)
                             for w in ("before", "after")
                             for k in ("delta_bic", "evidence", "gap", "role")}}
            for e in order]
