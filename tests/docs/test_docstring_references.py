"""Cross-references in docstrings stay on one line.

autosummary renders a docstring's first sentence alone, so a role broken across lines
(``:class:`~a.b.`` then ``C``` on the next line) leaves an unterminated interpreted
text there, which the docs build (warnings are errors) refuses; elsewhere the broken
target silently links nowhere.  The build runs only after the suite in CI, so this
catches it early.
"""

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
