"""Decode PYON, the text ARTIQ stores a run's ``expid`` in.

PYON (sipyco's "Python Object Notation") is Python literal syntax plus the
names ``null``, ``true``, ``false``, ``nan`` and ``inf`` and a few calls
(``nparray``, ``npscalar``, ``Fraction``, ``OrderedDict``).  sipyco decodes it
with ``eval``; written by hand here on :mod:`ast` because reading a results
file must never execute what is in it, and sipyco is not a dependency a lab
that only analyses its files needs.
"""

from __future__ import annotations

import ast
import base64
import math
from collections import OrderedDict
from fractions import Fraction

import numpy as np

__all__ = ["decode_pyon", "PyonError"]

_NAMES = {"null": None, "None": None, "true": True, "True": True, "false": False,
          "False": False, "nan": math.nan, "inf": math.inf}


class PyonError(ValueError):
    """Text that is not PYON (or uses a construct a data file has no business holding)."""


def decode_pyon(text: str):
    """The Python value of PYON ``text`` (``bytes`` are decoded as UTF-8).

    Raises
    ------
    PyonError
        Not PYON, or an expression other than literals and PYON's calls.
    """
    if isinstance(text, bytes):
        text = text.decode("utf-8")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise PyonError(f"not PYON text ({exc.msg})") from None
    return _value(tree.body)


def _value(node):
    if isinstance(node, ast.Constant):
        return node.value
    if isinstance(node, ast.Name):
        if node.id in _NAMES:
            return _NAMES[node.id]
        raise PyonError(f"unknown name {node.id!r}")
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        v = _value(node.operand)
        if not isinstance(v, (int, float)) or isinstance(v, bool):
            raise PyonError("a sign before something that is not a number")
        return -v if isinstance(node.op, ast.USub) else v
    if isinstance(node, ast.Dict):
        return {_value(k): _value(v) for k, v in zip(node.keys, node.values)}
    if isinstance(node, ast.List):
        return [_value(v) for v in node.elts]
    if isinstance(node, ast.Tuple):
        return tuple(_value(v) for v in node.elts)
    if isinstance(node, ast.Set):
        return {_value(v) for v in node.elts}
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and not node.keywords:
        args = [_value(a) for a in node.args]
        return _call(node.func.id, args)
    raise PyonError(f"unsupported expression ({type(node).__name__})")


def _call(name: str, args: list):
    if name == "Fraction" and len(args) == 2:
        return Fraction(*args)
    if name == "OrderedDict" and len(args) <= 1:
        return OrderedDict(*args)
    if name == "slice":
        return slice(*args)
    if name == "nparray" and len(args) == 3:          # shape, dtype, base64 of the bytes
        shape, dtype, data = args
        return np.frombuffer(base64.b64decode(data), dtype=dtype).copy().reshape(shape)
    if name == "npscalar" and len(args) == 2:         # dtype, base64 of the bytes
        dtype, data = args
        return np.frombuffer(base64.b64decode(data), dtype=dtype)[0]
    raise PyonError(f"unsupported call {name}(...)")
