"""The fields of a diagnosis's JSON that a comparison reads, checked before any is used.

An earlier diagnosis (``dpdfit diagnose --json`` written to a file) may have been edited
by hand or come from elsewhere.  :func:`check_diagnosis_fields` checks every field that
the comparison (:mod:`~dpdfit.analyses.diagnosis.comparison`) and the refit of the
earlier proposal's binding pair (:func:`~dpdfit.analyses.diagnosis.comparison.previous.refit_request`)
read -- its type, and where one is read as a number, that it is one a float holds -- so
that a bad value is one :class:`~dpdfit.errors.InputError` naming the file and the key
path (``'next_measurement.binding.truth.forms[0]' must be text or null, not a list``)
before anything is fitted, not an error deep inside the fits.

The fields (:data:`DIAGNOSIS_FIELDS`; ``null`` is allowed where the diagnosis writes it):

* ``campaign``, ``verdict``: text;
* ``effects``: a list of ``{"effect": text}``;
* ``ranking``: a list of ``{"effect": text}`` with the numbers ``delta_bic``,
  ``delta_bic_tempered`` and ``family_delta_bic_tempered``;
* ``alternatives``: a list of ``{"effect": text}`` with ``named`` (a list of text),
  ``replaces`` (text) and the numbers ``delta_bic``, ``delta_bic_tempered``;
* ``next_measurement``: ``what`` and ``reason`` (text), ``expected_delta_bic`` (a
  number), ``decisive`` (true or false), ``settings`` (an object) and ``binding``, whose
  ``truth`` and ``rival`` are hypotheses;
* ``refits``: a list of hypotheses;

a hypothesis being ``effects`` (a list of text), ``forms`` (a list of text or null, one
per effect) and the numbers ``chi2`` and ``expected_delta_bic``.  Other keys are not
read, and not checked.
"""

from __future__ import annotations

from dataclasses import dataclass

from dpdfit.errors import InputError

__all__ = ["DIAGNOSIS_FIELDS", "check_diagnosis_fields"]


@dataclass(frozen=True)
class _Kind:
    """A JSON value's kind: its words in a message, and the test."""

    words: str
    test: object

    def holds(self, value) -> bool:
        return self.test(value)


def _is_number(v) -> bool:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return False
    try:
        float(v)                   # an integer of 400 digits is JSON, not a float
    except OverflowError:
        return False
    return True


_TEXT = _Kind("text", lambda v: isinstance(v, str))
_NUMBER = _Kind("a number", _is_number)
_FLAG = _Kind("true or false", lambda v: isinstance(v, bool))


@dataclass(frozen=True)
class _Maybe:
    """``null``, or a value of ``kind``."""

    kind: object


@dataclass(frozen=True)
class _ListOf:
    """A list of values of ``item``."""

    item: object


@dataclass(frozen=True)
class _Object:
    """An object: the ``required`` keys present, the keys of ``fields`` (where present)
    of their kinds, other keys not read."""

    fields: dict
    required: tuple = ()


_HYPOTHESIS = _Object({"effects": _Maybe(_ListOf(_TEXT)), "forms": _Maybe(_ListOf(_Maybe(_TEXT))),
                       "chi2": _Maybe(_NUMBER), "expected_delta_bic": _Maybe(_NUMBER)})

#: the fields of a diagnosis's JSON a comparison reads, with their kinds (module doc)
DIAGNOSIS_FIELDS = _Object({
    "campaign": _TEXT,
    "verdict": _TEXT,
    "effects": _ListOf(_Object({"effect": _TEXT}, required=("effect",))),
    "ranking": _ListOf(_Object({"effect": _TEXT, "delta_bic": _Maybe(_NUMBER),
                                "delta_bic_tempered": _Maybe(_NUMBER),
                                "family_delta_bic_tempered": _Maybe(_NUMBER)},
                               required=("effect",))),
    "alternatives": _Maybe(_ListOf(_Object(
        {"effect": _TEXT, "named": _Maybe(_ListOf(_TEXT)), "replaces": _Maybe(_TEXT),
         "delta_bic": _Maybe(_NUMBER), "delta_bic_tempered": _Maybe(_NUMBER)},
        required=("effect",)))),
    "next_measurement": _Maybe(_Object({
        "what": _Maybe(_TEXT), "reason": _Maybe(_TEXT),
        "expected_delta_bic": _Maybe(_NUMBER), "decisive": _Maybe(_FLAG),
        "settings": _Maybe(_Object({})),
        "binding": _Maybe(_Object({"truth": _Maybe(_HYPOTHESIS),
                                   "rival": _Maybe(_HYPOTHESIS)}))})),
    "refits": _Maybe(_ListOf(_HYPOTHESIS)),
}, required=("campaign", "verdict", "effects", "ranking"))


def _words(spec) -> str:
    if isinstance(spec, _Kind):
        return spec.words
    if isinstance(spec, _Maybe):
        return f"{_words(spec.kind)} or null"
    return "a list" if isinstance(spec, _ListOf) else "an object"


def _kind_of(value) -> str:
    """What a JSON value is, in a message's words."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true/false"
    if isinstance(value, (int, float)):
        return "a number" if _is_number(value) else "a number beyond a float's range"
    return {str: "text", list: "a list", dict: "an object"}.get(type(value),
                                                                type(value).__name__)


def _join(path: str, key) -> str:
    return f"{path}[{key}]" if isinstance(key, int) else (f"{path}.{key}" if path else key)


def _check(value, spec, path: str, fail) -> None:
    """``value`` against ``spec``; ``fail(path, message)`` at the first that does not
    hold.  It recurses as deep as the fields go (a few levels), not as the value does."""
    nullable = isinstance(spec, _Maybe)
    if nullable:
        if value is None:
            return
        spec = spec.kind
    kind = {_ListOf: list, _Object: dict}.get(type(spec))
    if not (spec.holds(value) if kind is None else isinstance(value, kind)):
        fail(path, f"must be {_words(spec)}{' or null' if nullable else ''}, "
                   f"not {_kind_of(value)}")
    if isinstance(spec, _ListOf):
        for i, v in enumerate(value):
            _check(v, spec.item, _join(path, i), fail)
    elif isinstance(spec, _Object):
        missing = [k for k in spec.required if k not in value]
        if missing:
            fail(path, f"{f'{path!r} has' if path else 'has'} no '{missing[0]}'", whole=True)
        for k, s in spec.fields.items():
            if k in value:
                _check(value[k], s, _join(path, k), fail)


def _hypotheses(d: dict):
    """``(key path, hypothesis)`` of every hypothesis the diagnosis holds."""
    nxt = d.get("next_measurement")
    binding = nxt.get("binding") if isinstance(nxt, dict) else None
    for side in ("truth", "rival"):
        if isinstance(binding, dict) and isinstance(binding.get(side), dict):
            yield f"next_measurement.binding.{side}", binding[side]
    for i, h in enumerate(d.get("refits") or []):
        yield f"refits[{i}]", h


def check_diagnosis_fields(d: dict, where: str | None) -> None:
    """Every field of diagnosis dict ``d`` that a comparison reads (module doc), or an
    :class:`~dpdfit.errors.InputError` naming the file ``where`` and the key path; also a
    hypothesis whose ``forms`` are not one per effect (a refit would pair them wrongly)."""
    def fail(path, message, whole=False):
        text = message if whole else f"'{path}' {message}"
        raise InputError(f"not a dpdfit diagnosis: {text}", file=where)

    _check(d, DIAGNOSIS_FIELDS, "", fail)
    for path, h in _hypotheses(d):
        effects, forms = h.get("effects"), h.get("forms")
        if effects is not None and forms is not None and len(forms) != len(effects):
            fail(f"{path}.forms", f"holds {len(forms)} forms for {len(effects)} effects "
                                  "(one per effect)")
