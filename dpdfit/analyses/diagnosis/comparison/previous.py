"""The earlier diagnosis a comparison starts from: its JSON read and checked
(:func:`read_diagnosis`, :func:`as_diagnosis_dict`), and its proposal's binding pair as
the later diagnosis is asked to refit it (:func:`refit_request`; none when the catalog
cannot, :func:`unknown_in_binding`)."""

from __future__ import annotations

import json
import math
import os

from dpdfit.analyses.diagnosis.comparison.diagnosis_fields import check_diagnosis_fields
from dpdfit.analyses.diagnosis.comparison.refits import binding_refits
from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.core.jsonable import to_jsonable
from dpdfit.errors import InputError
from dpdfit.recordings.input_files import read_input_json

__all__ = ['DIAGNOSIS_KEYS', 'read_diagnosis', 'as_diagnosis_dict', 'named_in', 'json_number', 'hypothesis_label', 'refit_request', 'unknown_in_binding']


#: the keys every diagnosis JSON has (``dpdfit diagnose --json``): what marks a file as one
DIAGNOSIS_KEYS = ("campaign", "verdict", "effects", "ranking")


def _check(d, where: str | None) -> dict:
    missing = ([] if not isinstance(d, dict) else [k for k in DIAGNOSIS_KEYS if k not in d])
    if not isinstance(d, dict) or missing:
        what = (f"a JSON {type(d).__name__}" if not isinstance(d, dict)
                else f"no {', '.join(repr(k) for k in missing)}")
        raise InputError(f"not a dpdfit diagnosis ({what}; expected the output of "
                         f"'dpdfit diagnose --json')", file=where)
    check_diagnosis_fields(d, where)
    return d


def read_diagnosis(path: str | os.PathLike) -> dict:
    """The JSON dict of an earlier diagnosis (``dpdfit diagnose --json`` written to a
    file); an :class:`~dpdfit.errors.InputError` naming the file when it is not a regular
    file, is larger than :data:`~dpdfit.core.defaults.MAX_JSON_BYTES`, is not JSON or is
    not a dpdfit diagnosis (a field the comparison reads of another type:
    :func:`~dpdfit.analyses.diagnosis.comparison.diagnosis_fields.check_diagnosis_fields`).
    It is read through :func:`~dpdfit.recordings.input_files.read_input_json`: a FIFO or a
    device is refused, not read."""
    try:
        d = read_input_json(path, what="diagnosis JSON file")
    except InputError as exc:
        bad = exc.__context__                 # the parser's error, when it is one
        if not isinstance(bad, json.JSONDecodeError):
            raise
        raise InputError(f"not JSON ({bad.msg}, line {bad.lineno}); expected the output "
                         "of 'dpdfit diagnose --json'", file=str(path)) from None
    return _check(d, str(path))


def as_diagnosis_dict(d) -> dict:
    """A :class:`~dpdfit.analyses.diagnosis.result.Diagnosis`, its JSON dict or a path to
    that JSON, as the JSON dict (NaN as None, as ``--json`` writes it)."""
    if isinstance(d, (str, os.PathLike)):
        return read_diagnosis(d)
    if hasattr(d, "to_dict") and not isinstance(d, dict):
        d = d.to_dict()
    return _check(to_jsonable(d), None)


def named_in(d: dict) -> list:
    """The effects a diagnosis's JSON dict names, best first."""
    return [e["effect"] for e in d.get("effects") or [] if isinstance(e, dict)]


def json_number(v):
    """A number of a diagnosis's JSON as a finite float, else None (a missing key, null,
    NaN or text)."""
    try:
        v = float(v)
    except (TypeError, ValueError, OverflowError):
        return None
    return v if math.isfinite(v) else None


def hypothesis_label(effects) -> str:
    """A hypothesis's effects as one label, e.g. ``"stale_calibration + dephasing"``."""
    return " + ".join(effects or []) or "baseline"


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
