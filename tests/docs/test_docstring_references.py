"""Cross-references in docstrings stay on one line; kets are literals.

autosummary renders a docstring's first sentence alone, so a role broken across lines
(``:class:`~a.b.`` then ``C``` on the next line) leaves an unterminated interpreted
text there, which the docs build (warnings are errors) refuses; elsewhere the broken
target silently links nowhere.  The build runs only after the suite in CI, so this
catches it early.

A ket written bare (``|00>``) starts a docutils substitution reference, which the build
refuses too: in docstrings and ``#:`` attribute comments, kets go inside double
backquotes.
"""

import ast
import re
from pathlib import Path

import dpdfit

ROLE_BROKEN_ACROSS_LINES = re.compile(r":(?:class|func|meth|mod|attr|data|exc|obj):`[^`\n]*\n")


def test_no_cross_reference_is_broken_across_lines():
    root = Path(dpdfit.__file__).parent
    broken = []
    for path in sorted(root.rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        for match in ROLE_BROKEN_ACROSS_LINES.finditer(text):
            line = text.count("\n", 0, match.start()) + 1
            broken.append(f"{path.relative_to(root.parent)}:{line}")
    assert broken == []


BARE_KET = re.compile(r"\|[01]{1,2}>")
LITERAL = re.compile(r"``.*?``", re.S)


def _rendered_texts(text: str):
    """``(line, text)`` of every docstring and ``#:`` comment of a module's source."""
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef,
                             ast.AsyncFunctionDef)):
            doc = ast.get_docstring(node, clean=False)
            if doc:
                yield node.body[0].lineno, doc
    for i, line in enumerate(text.splitlines(), 1):
        if line.lstrip().startswith("#:"):
            yield i, line


def test_no_bare_ket_in_a_rendered_docstring():
    root = Path(dpdfit.__file__).parent
    bare = []
    for path in sorted(root.rglob("*.py")):
        for line, doc in _rendered_texts(path.read_text(encoding="utf-8")):
            if BARE_KET.search(LITERAL.sub("", doc)):
                bare.append(f"{path.relative_to(root.parent)}:{line}")
    assert bare == []
