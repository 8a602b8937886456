"""Decode PYON, the text ARTIQ stores a run's ``expid`` in.

PYON (sipyco's "Python Object Notation") is Python literal syntax plus the
names ``null``, ``true``, ``false``, ``nan`` and ``inf`` and a few calls
(``nparray``, ``npscalar``, ``Fraction``, ``OrderedDict``, ``slice``).  sipyco
decodes it with ``eval``; written by hand here on :mod:`ast` because reading a
results file must never execute what is in it, and sipyco is not a dependency a
lab that only analyses its files needs.

Whatever the text, the decoder returns a value or raises :class:`PyonError` with
one line saying why.  The text is bounded (:mod:`dpdfit.core.defaults`): at most
``PYON_MAX_CHARS`` characters nested at most ``PYON_MAX_DEPTH`` deep, integers
within int64 (``INTEGER_MAX``), arrays of numbers, text or bytes (no object
arrays, which numpy cannot read from bytes anyway).
"""

from __future__ import annotations

import ast
import base64
import binascii
import math
from collections import OrderedDict
from fractions import Fraction

import numpy as np

from dpdfit.core.defaults import INTEGER_MAX, PYON_MAX_CHARS, PYON_MAX_DEPTH

__all__ = ["decode_pyon", "PyonError"]

_NAMES = {"null": None, "None": None, "true": True, "True": True, "false": False,
          "False": False, "nan": math.nan, "inf": math.inf}
#: numpy dtype kinds an array may have: booleans, numbers, bytes and text
_ARRAY_KINDS = "biufcSU"


class PyonError(ValueError):
    """Text that is not PYON (or uses a construct a data file has no business holding)."""


def decode_pyon(text: str):
    """The Python value of PYON ``text`` (``bytes`` are decoded as UTF-8).

    Raises
    ------
    PyonError
        Not PYON, or an expression other than literals and PYON's calls, or beyond
        the bounds (module doc).
    """
    if isinstance(text, bytes):
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError:
            raise PyonError("not UTF-8 text") from None
    if not isinstance(text, str):
        raise PyonError(f"not text (a {type(text).__name__})")
    if len(text) > PYON_MAX_CHARS:
        raise PyonError(f"{len(text)} characters long (at most {PYON_MAX_CHARS})")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        # (an over-long integer's message goes on about sys.set_int_max_str_digits)
        raise PyonError(f"not PYON text ({exc.msg.partition(';')[0]})") from None
    except (RecursionError, MemoryError):
        # CPython's parser gives up on a long chain of operators or signs with these
        raise PyonError(f"nested deeper than {PYON_MAX_DEPTH} levels") from None
    _check_depth(tree.body)
    return _value(tree.body)


def _check_depth(body) -> None:
    """Refuse nesting beyond PYON_MAX_DEPTH, walking the tree without recursion (the
    decoder recurses once per level)."""
    todo = [(body, 1)]
    while todo:
        node, depth = todo.pop()
        if depth > PYON_MAX_DEPTH:
            raise PyonError(f"nested deeper than {PYON_MAX_DEPTH} levels")
        todo += [(c, depth + 1) for c in ast.iter_child_nodes(node)]


def _value(node):
    if isinstance(node, ast.Constant):
        return _constant(node.value)
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
        if any(k is None for k in node.keys):
            raise PyonError("unsupported expression (** in a dictionary)")
        return _hashed(lambda: {_value(k): _value(v) for k, v in zip(node.keys, node.values)})
    if isinstance(node, ast.List):
        return [_value(v) for v in node.elts]
    if isinstance(node, ast.Tuple):
        return tuple(_value(v) for v in node.elts)
    if isinstance(node, ast.Set):
        return _hashed(lambda: {_value(v) for v in node.elts})
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and not node.keywords:
        args = [_value(a) for a in node.args]
        return _call(node.func.id, args)
    raise PyonError(f"unsupported expression ({type(node).__name__})")


def _constant(v):
    if v is Ellipsis:
        raise PyonError("unsupported expression (...)")
    if type(v) is int and abs(v) > INTEGER_MAX:
        raise PyonError(f"an integer beyond int64 ({v.bit_length()} bits)")
    return v


def _hashed(build):
    """A dictionary or set from ``build``; a key that cannot be one (a list, a
    dictionary) is refused."""
    try:
        return build()
    except TypeError as exc:                      # unhashable type: 'list'
        raise PyonError(f"a dictionary key or set member is not hashable ({exc})") from None


def _call(name: str, args: list):
    try:
        if name == "Fraction" and len(args) == 2:
            if not all(type(a) is int for a in args):
                raise PyonError("Fraction(...) takes two integers")
            return Fraction(*args)
        if name == "OrderedDict" and len(args) <= 1:
            return OrderedDict(*args)
        if name == "slice" and len(args) <= 3:
            if not all(a is None or type(a) is int for a in args):
                raise PyonError("slice(...) takes integers or null")
            return slice(*args)
        if name == "nparray" and len(args) == 3:      # shape, dtype, base64 of the bytes
            shape, dtype, data = args
            if not (isinstance(shape, (tuple, list)) and all(type(s) is int for s in shape)):
                raise PyonError("nparray(...): the shape is not a tuple of integers")
            return np.frombuffer(_bytes(data), dtype=_dtype(dtype)).copy().reshape(shape)
        if name == "npscalar" and len(args) == 2:     # dtype, base64 of the bytes
            dtype, data = args
            return np.frombuffer(_bytes(data), dtype=_dtype(dtype))[0]
    except PyonError:
        raise
    except (TypeError, ValueError, ZeroDivisionError, IndexError) as exc:
        # Fraction(1, 0), OrderedDict(5), a shape that does not fit the data, no data
        raise PyonError(f"{name}(...) cannot be built ({exc})") from None
    raise PyonError(f"unsupported call {name}(...)")


def _bytes(data) -> bytes:
    if not isinstance(data, (str, bytes)):
        raise PyonError("the data of an array is not base64 text")
    try:
        return base64.b64decode(data)
    except (binascii.Error, ValueError) as exc:
        raise PyonError(f"the data of an array is not base64 ({exc})") from None


def _dtype(dtype) -> np.dtype:
    if not isinstance(dtype, str):
        raise PyonError("the dtype of an array is not a string")
    try:
        dt = np.dtype(dtype)
    except (TypeError, ValueError):
        raise PyonError(f"the dtype {dtype!r} is not a numpy dtype") from None
    if dt.kind not in _ARRAY_KINDS or dt.itemsize == 0:
        raise PyonError(f"the dtype {dtype!r} is not one of numbers, text or bytes")
    return dt
