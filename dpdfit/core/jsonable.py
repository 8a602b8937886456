"""The one conversion of results to plain Python (for JSON files and for display).

numpy scalars and arrays, tuples, pandas frames and objects with ``to_dict``
become dicts, lists, ints, floats, bools and strings.  JSON has no NaN or
infinity: :func:`to_jsonable` writes them as ``null`` (an absent value) unless
``finite_only=False`` (the notebook views, which show ``nan``).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["to_jsonable", "json_kind"]

_JSON_KINDS = ((bool, "boolean"), (dict, "object"), (list, "list"), (str, "string"),
               ((int, float), "number"), (type(None), "null"))


def json_kind(value) -> str:
    """How JSON names the kind of a parsed value (a refusal names the kind, never a
    Python repr): object, list, string, number, boolean or null."""
    return next((k for t, k in _JSON_KINDS if isinstance(value, t)), type(value).__name__)


def to_jsonable(obj, *, finite_only: bool = True):
    """``obj`` as plain Python, recursively (module doc)."""
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v, finite_only=finite_only) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v, finite_only=finite_only) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist(), finite_only=finite_only)
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float):
        return None if finite_only and not math.isfinite(obj) else obj
    if hasattr(obj, "to_dict") and not isinstance(obj, type):
        try:
            return to_jsonable(obj.to_dict(orient="records"), finite_only=finite_only)  # frame
        except TypeError:
            return to_jsonable(obj.to_dict(), finite_only=finite_only)
    return obj
