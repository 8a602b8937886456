"""Computed mapping columns: a small arithmetic language over a results file's sources.

A mapping column may be ``{ expr = "..." }``, an expression such as
``"round(channel('p_even') * argument('shots'))"`` or
``"dataset('sum11') + dataset('sum12')"``.  It may use

* the sources a column names: ``axis('name')``, ``channel('name')``,
  ``dataset('name')``, ``argument('name')``, ``parameter('fqn')`` (each with one
  string, the name, as the column sources ``axis = ...`` etc. take it);
* ``source[:, k]``, column ``k`` of a source that holds a row of values per point
  (``dataset('ratio_list')[:, 2]``);
* numbers, ``+ - * / // % **`` and unary ``-``/``+``;
* ``round(x)`` (or ``round(x, digits)``) and ``sum([a, b, ...])``;

and nothing else.  The text is parsed with :mod:`ast` and every node checked
against that whitelist when the mapping is read (so a mistake is reported with
the mapping key and line before any results file is opened); it is then
interpreted node by node with numpy, elementwise over the rows.  ``eval`` is
never used: the standard library has no safe evaluator for a whitelist this
small, and a general one (numexpr, asteval) would let in more than the mapping
needs.

An expression is bounded (:mod:`dpdfit.core.defaults`): at most
``EXPR_MAX_CHARS`` characters, ``EXPR_MAX_NODES`` parts nested at most
``EXPR_MAX_DEPTH`` deep, integers up to ``EXPR_MAX_INTEGER`` (float64 holds them
exactly) and ``round`` to at most ``EXPR_MAX_ROUND_DIGITS`` places.
"""

from __future__ import annotations

import ast
import copy
import operator
from dataclasses import dataclass

import numpy as np

from dpdfit.core.defaults import (EXPR_MAX_CHARS, EXPR_MAX_DEPTH, EXPR_MAX_INTEGER,
                                  EXPR_MAX_NODES, EXPR_MAX_ROUND_DIGITS)

from .name_patterns import fill

__all__ = ["Expression", "ExpressionError", "parse_expression", "SOURCE_FUNCTIONS"]

#: functions that read a source of the results file (one string argument: the name)
SOURCE_FUNCTIONS = ("axis", "channel", "dataset", "argument", "parameter")
_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
           ast.Div: operator.truediv, ast.FloorDiv: operator.floordiv, ast.Mod: operator.mod,
           ast.Pow: operator.pow}
_UNARY = {ast.USub: operator.neg, ast.UAdd: operator.pos}
_ALLOWED = ("numbers, + - * / // % **, round(x[, digits]), sum([...]) and the sources "
            + ", ".join(f"{f}('name')" for f in SOURCE_FUNCTIONS) + " (or a column of one, "
            "dataset('name')[:, k])")


class ExpressionError(ValueError):
    """An expression outside the whitelist, or one that cannot be parsed."""


@dataclass(frozen=True)
class Expression:
    """A checked expression: its text and the sources it reads, in order of appearance."""

    text: str
    references: tuple
    tree: ast.Expression

    def evaluate(self, lookup) -> np.ndarray:
        """The expression's value, elementwise: ``lookup(source, name, column)`` gives
        each source's values (an array, one per row, or a scalar), or with an integer
        ``column`` that column of a source holding a row of values per point."""
        # overflow and 0/0 give inf and nan, which the column's finite check names
        with np.errstate(all="ignore"):
            return np.asarray(_value(self.tree.body, lookup), dtype=float)

    def filled(self, key: dict) -> Expression:
        """The expression with ``{placeholder}`` in its source names replaced by ``key``.

        The names are replaced in the checked tree, not in the text (a name from the
        results file may hold a quote, which would make the text no expression)."""
        tree = copy.deepcopy(self.tree)
        for node in ast.walk(tree):
            if isinstance(node, ast.Call) and node.func.id in SOURCE_FUNCTIONS:
                node.args[0].value = fill(node.args[0].value, key)
        text = self.text
        for k, v in key.items():
            text = text.replace("{" + k + "}", str(v))
        refs = tuple((f, fill(n, key)) for f, n in self.references)
        return Expression(text=text, references=refs, tree=tree)


def parse_expression(text: str) -> Expression:
    """Parse and check ``text`` (module doc); ExpressionError naming the part refused."""
    if not isinstance(text, str) or not text.strip():
        raise ExpressionError("must be a non-empty string")
    if len(text) > EXPR_MAX_CHARS:
        raise ExpressionError(f"is {len(text)} characters long (at most {EXPR_MAX_CHARS})")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise ExpressionError(f"'{text}' is not an expression ({exc.msg})") from None
    except (RecursionError, MemoryError):
        # CPython's parser gives up on a long chain of operators or signs with these
        raise ExpressionError(f"nests operators and calls more than {EXPR_MAX_DEPTH} "
                              "levels deep") from None
    _check_size(tree.body)
    refs = []
    _check(tree.body, refs)
    return Expression(text=text.strip(), references=tuple(refs), tree=tree)


def _check_size(body) -> None:
    """Refuse a tree beyond the bounds (module doc), walking it without recursion
    (the checker and the evaluator recurse once per level)."""
    nodes, todo = 0, [(body, 1)]
    while todo:
        node, depth = todo.pop()
        nodes += 1
        if depth > EXPR_MAX_DEPTH:
            raise ExpressionError(f"nests operators and calls more than {EXPR_MAX_DEPTH} "
                                  "levels deep")
        if nodes > EXPR_MAX_NODES:
            raise ExpressionError(f"has more than {EXPR_MAX_NODES} parts (numbers, sources, "
                                  "operators)")
        if isinstance(node, ast.Constant) and type(node.value) is int \
                and abs(node.value) > EXPR_MAX_INTEGER:
            raise ExpressionError(f"an integer is larger than {EXPR_MAX_INTEGER} (expressions "
                                  "compute in float64, which holds integers exactly up to "
                                  "there)")
        todo += [(c, depth + 1) for c in ast.iter_child_nodes(node)
                 if not isinstance(c, ast.expr_context)]


def _refuse(node, why: str = ""):
    part = ast.unparse(node)
    raise ExpressionError(f"'{part}' is not allowed{why}; an expression may use {_ALLOWED}")


def _check(node, refs: list) -> None:
    if isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
            _refuse(node, " (a constant must be a number)")
    elif isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        _check(node.left, refs)
        _check(node.right, refs)
    elif isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
        _check(node.operand, refs)
    elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and not node.keywords:
        _check_call(node, node.func.id, refs)
    elif isinstance(node, ast.Subscript) and _column_of(node) is not None:
        _check_call(node.value, node.value.func.id, refs)
    else:
        _refuse(node)


def _column_of(node: ast.Subscript):
    """``k`` of ``source(...)[:, k]`` (a whole number), else None."""
    sl, v = node.slice, node.value
    if not (isinstance(v, ast.Call) and isinstance(v.func, ast.Name)
            and v.func.id in SOURCE_FUNCTIONS and isinstance(sl, ast.Tuple)
            and len(sl.elts) == 2):
        return None
    every, k = sl.elts
    if not (isinstance(every, ast.Slice) and every.lower is None and every.upper is None
            and every.step is None):
        return None
    if isinstance(k, ast.UnaryOp) and isinstance(k.op, ast.USub) \
            and isinstance(k.operand, ast.Constant) and type(k.operand.value) is int:
        return -k.operand.value
    return k.value if isinstance(k, ast.Constant) and type(k.value) is int else None


def _check_call(node: ast.Call, fn: str, refs: list) -> None:
    args = node.args
    if fn in SOURCE_FUNCTIONS:
        if len(args) != 1 or not isinstance(args[0], ast.Constant) \
                or not isinstance(args[0].value, str):
            _refuse(node, f" ({fn}() takes one name in quotes)")
        refs.append((fn, args[0].value))
    elif fn == "round":
        if not 1 <= len(args) <= 2 or (len(args) == 2 and not (
                isinstance(args[1], ast.Constant) and type(args[1].value) is int)):
            _refuse(node, " (round takes a value and optionally a whole number of digits)")
        if len(args) == 2 and abs(args[1].value) > EXPR_MAX_ROUND_DIGITS:
            _refuse(node, f" (round keeps at most {EXPR_MAX_ROUND_DIGITS} digits)")
        _check(args[0], refs)
    elif fn == "sum":
        if len(args) != 1 or not isinstance(args[0], ast.List) or not args[0].elts:
            _refuse(node, " (sum takes a list: sum([a, b]))")
        for e in args[0].elts:
            _check(e, refs)
    else:
        _refuse(node)


def _value(node, lookup):
    if isinstance(node, ast.Constant):
        return node.value
    if isinstance(node, ast.BinOp):
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            return _BINARY[type(node.op)](np.asarray(_value(node.left, lookup), dtype=float),
                                          np.asarray(_value(node.right, lookup), dtype=float))
    if isinstance(node, ast.UnaryOp):
        return _UNARY[type(node.op)](np.asarray(_value(node.operand, lookup), dtype=float))
    if isinstance(node, ast.Subscript):
        return lookup(node.value.func.id, node.value.args[0].value, _column_of(node))
    fn, args = node.func.id, node.args
    if fn in SOURCE_FUNCTIONS:
        return lookup(fn, args[0].value, None)
    if fn == "round":
        digits = args[1].value if len(args) == 2 else 0
        return np.round(np.asarray(_value(args[0], lookup), dtype=float), digits)
    total = 0.0                                                       # sum([...])
    for e in args[0].elts:
        total = total + np.asarray(_value(e, lookup), dtype=float)
    return total
