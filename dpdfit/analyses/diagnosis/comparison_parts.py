"""The pieces of a comparison of two diagnoses of one campaign, before and after further
recordings (:mod:`~dpdfit.analyses.diagnosis.comparison`), each read from the two
diagnoses' JSON dicts (:meth:`~dpdfit.analyses.diagnosis.result.Diagnosis.to_dict`):

* :func:`read_diagnosis`: a diagnosis JSON file (``dpdfit diagnose --json``), checked;
* :func:`as_diagnosis_dict`: a Diagnosis, its dict or a file, as that dict;
* :func:`refit_request`: the earlier proposal's binding pair, as the later diagnosis is
  asked to refit it (none when the catalog cannot, :func:`unknown_in_binding`);
* :func:`alternatives_standing`: where each earlier alternative stands now (``named``,
  ``open`` or ``rejected``) and which alternatives are new;
* :func:`evidence_rows`: every single effect's evidence (its family's delta BIC against
  the baseline, tempered, as the ranking orders them) before and after, and its gap to
  the best;
* :func:`separation`: the separation the recordings achieved between the earlier
  proposal's binding pair against the one it predicted;
* :func:`proposal_after`: whether the later diagnosis proposes another recording.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.analyses.diagnosis.refits import (achieved_separation, binding_chi2,
                                              binding_refits, refitted_chi2)
from dpdfit.core.jsonable import to_jsonable
from dpdfit.errors import InputError

__all__ = ["DIAGNOSIS_KEYS", "EVIDENCE_KEYS", "read_diagnosis", "as_diagnosis_dict",
           "hypothesis_label", "refit_request", "unknown_in_binding",
           "alternatives_standing", "evidence_rows", "separation", "proposal_after"]

#: the keys every diagnosis JSON has (``dpdfit diagnose --json``): what marks a file as one
DIAGNOSIS_KEYS = ("campaign", "verdict", "effects", "ranking")


def _check(d, where: str | None) -> dict:
    missing = ([] if not isinstance(d, dict) else [k for k in DIAGNOSIS_KEYS if k not in d])
    if not isinstance(d, dict) or missing:
        what = (f"a JSON {type(d).__name__}" if not isinstance(d, dict)
                else f"no {', '.join(repr(k) for k in missing)}")
        raise InputError(f"not a dpdfit diagnosis ({what}; expected the output of "
                         f"'dpdfit diagnose --json')", file=where)
    if (not isinstance(d["verdict"], str) or not isinstance(d["ranking"], list)
            or not isinstance(d["effects"], list)):
        raise InputError("not a dpdfit diagnosis ('verdict' must be text, 'ranking' and "
                         "'effects' lists)", file=where)
    return d


def read_diagnosis(path: str | os.PathLike) -> dict:
    """The JSON dict of an earlier diagnosis (``dpdfit diagnose --json`` written to a
    file); an :class:`~dpdfit.errors.InputError` naming the file when it cannot be read,
    is not JSON or is not a dpdfit diagnosis."""
    where = str(path)
    p = Path(path)
    if p.is_dir():
        raise InputError("is a folder, not a diagnosis JSON file", file=where)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError("diagnosis JSON file not found", file=where) from None
    except (OSError, UnicodeDecodeError) as exc:
        why = getattr(exc, "strerror", None) or "not UTF-8 text"
        raise InputError(f"cannot be read ({why})", file=where) from None
    try:
        d = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"not JSON ({exc.msg}, line {exc.lineno}); expected the output "
                         "of 'dpdfit diagnose --json'", file=where) from None
    return _check(d, where)


def as_diagnosis_dict(d) -> dict:
    """A :class:`~dpdfit.analyses.diagnosis.result.Diagnosis`, its JSON dict or a path to
    that JSON, as the JSON dict (NaN as None, as ``--json`` writes it)."""
    if isinstance(d, (str, os.PathLike)):
        return read_diagnosis(d)
    if hasattr(d, "to_dict") and not isinstance(d, dict):
        d = d.to_dict()
    return _check(to_jsonable(d), None)


def _named(d: dict) -> list:
    return [e["effect"] for e in d.get("effects") or [] if isinstance(e, dict)]


def _key(a: dict) -> tuple:
    return tuple(sorted(a.get("named") or [a.get("effect")]))


def hypothesis_label(effects) -> str:
    """A hypothesis's effects as one label, e.g. ``"stale_calibration + dephasing"``."""
    return " + ".join(effects or []) or "baseline"


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
    named_after = _named(after)
    alts_after = [a for a in after.get("alternatives") or [] if isinstance(a, dict)]
    out, matched = [], []
    for a in before.get("alternatives") or []:
        if not isinstance(a, dict):
            continue
        status, now = _standing(a, named_after, alts_after)
        matched.append(now)
        out.append(_alt(a, status=status, delta_bic_tempered_after=(
            None if now is None else now.get("delta_bic_tempered"))))
    named_before = _named(before)
    # new: neither an earlier alternative still open nor the earlier named set
    new = [_alt(a) for a in alts_after if not any(a is m for m in matched)
           and _key(a) != tuple(sorted(named_before))]
    prev = (_standing({"effect": named_before[0] if named_before else None,
                       "named": named_before}, named_after, alts_after)[0]
            if named_before else "rejected")
    return out, new, prev


def _float(v):
    try:
        v = float(v)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


#: the evidence of a ranking entry, first found: its family's tempered delta BIC (what the
#: ranking orders by; each effect's own tempering differs, so its tempered delta BIC
#: against the baseline does not compare across effects), else its own, else the raw one
EVIDENCE_KEYS = ("family_delta_bic_tempered", "delta_bic_tempered", "delta_bic")


def _evidence(entry: dict):
    return next((v for v in map(_float, (entry.get(k) for k in EVIDENCE_KEYS))
                 if v is not None), None)


def _role(effect: str, d: dict) -> str | None:
    if effect in _named(d):
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


def _forms_of(effect: str):
    try:
        return {f.name for f in EFFECTS[effect].forms_for()}
    except Exception:                  # noqa: BLE001 - forms that need a campaign: not checked
        return None


def unknown_in_binding(proposal) -> list:
    """The effects (``"name"``) and forms (``"name[form]"``) of a proposal's binding pair
    that the catalog does not have (a diagnosis made with effects registered elsewhere):
    such a pair cannot be refitted here."""
    out = []
    for label in binding_refits(proposal) or []:
        effects = label.get("effects") if isinstance(label.get("effects"), list) else []
        forms = label.get("forms") if isinstance(label.get("forms"), list) else []
        for i, e in enumerate(effects):
            if not isinstance(e, str) or e not in EFFECTS:
                out.append(str(e))
                continue
            known, f = _forms_of(e), forms[i] if i < len(forms) else None
            if f is not None and known is not None and f not in known:
                out.append(f"{e}[{f}]")
    return list(dict.fromkeys(out))


def refit_request(previous: dict) -> list | None:
    """The ``refit`` list to give the later diagnosis
    (:func:`~dpdfit.analyses.diagnosis.diagnose.diagnose`): the earlier proposal's
    binding pair, or None without one or when the catalog cannot fit it
    (:func:`unknown_in_binding`)."""
    nxt = previous.get("next_measurement") if isinstance(previous, dict) else None
    if unknown_in_binding(nxt):
        return None
    return binding_refits(nxt)


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


def separation(before: dict, after: dict) -> dict:
    """The separation between the earlier proposal's binding pair that the recordings
    achieved (:func:`~dpdfit.analyses.diagnosis.refits.achieved_separation` of the pair's
    chi2 in the proposal and refitted by the later diagnosis) against the one predicted:
    ``what``, ``truth``, ``rival`` (labels), ``predicted`` (the proposal's
    ``expected_delta_bic``), ``predicted_if_truth`` / ``predicted_if_rival`` (the
    separation expected were that one true), ``chi2_before`` / ``chi2_after``
    (``{"truth", "rival"}``), ``achieved``, ``ratio`` (achieved / predicted) and
    ``reason`` (why a value is None; None when all are there)."""
    nxt = before.get("next_measurement")
    out = {"what": None, "settings": None, "truth": None, "rival": None, "predicted": None,
           "predicted_if_truth": None, "predicted_if_rival": None, "chi2_before": None,
           "chi2_after": None, "achieved": None, "ratio": None}
    why = _no_separation(before, nxt)
    if why is not None:
        return {**out, "what": (nxt or {}).get("what") if isinstance(nxt, dict) else None,
                "reason": why}
    b = nxt["binding"]
    out.update(what=nxt["what"], settings=nxt.get("settings"),
               predicted=_float(nxt.get("expected_delta_bic")),
               truth=hypothesis_label(b["truth"].get("effects")),
               rival=hypothesis_label(b["rival"].get("effects")),
               predicted_if_truth=_float(b["truth"].get("expected_delta_bic")),
               predicted_if_rival=_float(b["rival"].get("expected_delta_bic")),
               chi2_before=binding_chi2(nxt),
               chi2_after=refitted_chi2(nxt, after.get("refits")))
    if out["chi2_after"] is None:
        return {**out, "reason": "this diagnosis did not refit the previous proposal's "
                                 "binding pair (diagnose(..., refit=binding_refits("
                                 "previous next_measurement)))"}
    out["achieved"] = achieved_separation(out["chi2_before"], out["chi2_after"])
    p = out["predicted"]
    out["ratio"] = (out["achieved"] / p if p and p > 0 and out["achieved"] is not None
                    else None)
    return {**out, "reason": None if out["ratio"] is not None
            else "the previous proposal predicted no separation to compare with"}


def proposal_after(after: dict) -> dict:
    """Whether the later diagnosis proposes another recording: ``proposed``, ``what``,
    ``decisive``, ``expected_delta_bic`` and ``reason`` (its settings are the diagnosis's
    own ``next_measurement``)."""
    nxt = after.get("next_measurement")
    if not isinstance(nxt, dict):
        why = ("no effect is named" if not _named(after) else "none given"
               if after.get("alternatives") else "no alternatives and no poorly "
                                                 "constrained size")
        return {"proposed": False, "what": None, "decisive": None, "expected_delta_bic": None,
                "reason": why}
    return {"proposed": bool(nxt.get("what")), "what": nxt.get("what"),
            "decisive": nxt.get("decisive") if nxt.get("what") else None,
            "expected_delta_bic": _float(nxt.get("expected_delta_bic")),
            "reason": nxt.get("reason")}
