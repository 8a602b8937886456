"""Every place the documentation points a reader to is there.

Read over the guide pages (``docs/**/*.md``), ``README.md``, the markdown cells of the
example notebooks and the docstrings of the package:

* a repository path in inline code or a link (``datasets/...``, ``docs/...``,
  ``benchmarks/...``, ``scripts/...``, ``dpdfit/...``, ``tests/...``, ``examples/...``)
  exists, and a relative link resolves from the file that holds it;
* a "README section "X"" names a heading of ``README.md``;
* a reference to the paper is a number a reader of the paper can look up (``Eq. 3``,
  ``Eq. S11``, ``Sec. S6.3``), not a LaTeX label such as ``Eq. aom-forward``.
"""

from __future__ import annotations

import ast
import glob
import json
import os
import re
from pathlib import Path

import pytest

from tests.helpers.paths import ROOT

PREFIXES = ("datasets/", "docs/", "benchmarks/", "scripts/", "dpdfit/", "tests/", "examples/")

#: paths the pages tell the reader to create; they are not in the repository
CREATED_BY_THE_READER = {
    # the README's docs build command writes the site there
    "docs/_build/html/index.html",
    # docs/benchmarks.md: what a new run with `--json` would write, named as such
    "benchmarks/property_counts.json",
    # docs/diagnosis/adding-an-effect.md: the modules the page has the reader write
    "dpdfit/analyses/diagnosis/effects/third_order_pm.py",
    "dpdfit/simulation/injections/third_order_pm.py",
}

_INLINE = re.compile(r"(?<!`)(`+)(?!`)(.+?)(?<!`)\1(?!`)", re.S)
#: a role's target, such as {doc}`examples/analysis`, is a page name, not a path
_ROLE = re.compile(r"\{[\w:.-]+\}`[^`]*`")
#: a placeholder such as ``<seed>`` stands for any name
_PLACEHOLDER = re.compile(r"<[^<>`]*>")
_LINK = re.compile(r"\[[^\]\n]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
_FENCE = re.compile(r"^(```|~~~).*?^\1\s*$", re.S | re.M)
_README_SECTION = re.compile(
    r"README(?:'s|,)?\s+(?:section\s+)?\"([^\"]+)\"|section\s+\"([^\"]+)\"\s+of\s+the\s+README"
    # unquoted, a part of a document the README would need a heading for
    r"|README's\s+(walkthrough|tutorial|chapter|appendix)\b", re.I)
#: "Eq. 3", "Eqs. S4-S6", "Sec. S6.3", "Secs. S1-S2", "Table S2"; anything else after
#: Eq./Sec. that is a word is a label the paper's reader never sees
_PAPER_REF = re.compile(r"\b(Eqs?|Secs?)\.[ ~]*\(?([A-Za-z][\w-]*)")
_NUMBER = re.compile(r"S\d+(\.\d+)?(-S?\d+(\.\d+)?)?$")


def _markdown_sources() -> list[tuple[str, Path, str]]:
    """(label, folder the text's relative links start from, text) for every prose source."""
    out = []
    pages = sorted(p for p in (ROOT / "docs").rglob("*.md") if "_build" not in p.parts)
    for page in pages + [ROOT / "README.md"]:
        out.append((str(page.relative_to(ROOT)), page.parent,
                    _FENCE.sub("", page.read_text(encoding="utf-8"))))
    for nb in sorted((ROOT / "docs" / "examples").glob("*.ipynb")):
        cells = json.loads(nb.read_text(encoding="utf-8"))["cells"]
        for i, cell in enumerate(cells):
            if cell["cell_type"] == "markdown":
                out.append((f"{nb.relative_to(ROOT)} cell {i}", nb.parent,
                            _FENCE.sub("", "".join(cell["source"]))))
    return out


def _docstrings() -> list[tuple[str, Path, str]]:
    out = []
    for module in sorted((ROOT / "dpdfit").rglob("*.py")):
        tree = ast.parse(module.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef,
                                 ast.AsyncFunctionDef)):
                doc = ast.get_docstring(node, clean=False)
                if doc:
                    name = getattr(node, "name", "module")
                    out.append((f"{module.relative_to(ROOT)}:{name}", module.parent, doc))
    return out


SOURCES = _markdown_sources() + _docstrings()


def _repo_paths(text: str) -> list[str]:
    found = []
    for _, code in _INLINE.findall(_ROLE.sub("", text)):
        for token in _PLACEHOLDER.sub("*", code).split():
            token = token.strip("\"'(),;:")
            if token.startswith(PREFIXES):
                found.append(token)
    for target in _LINK.findall(text):
        target = target.split("#")[0]
        if target.startswith(PREFIXES):
            found.append(target)
    return found


def _relative_links(text: str) -> list[str]:
    """Link targets that are files: relative to the text's file, or to ``docs/`` with a "/"."""
    links = []
    for target in _LINK.findall(text):
        path = target.split("#")[0]
        if path and not re.match(r"[a-z][a-z0-9+.-]*:", path):
            links.append(path)
    return links


def _exists(path: str, base: Path = ROOT) -> bool:
    if path.startswith("/"):          # MyST: relative to the documentation's source folder
        path, base = path.lstrip("/"), ROOT / "docs"
    if "::" in path:                  # a pytest node id: the file and the test in it
        file, _, test = path.partition("::")
        return (_exists(file, base) and re.search(rf"^\s*def {re.escape(test.split('::')[-1])}\(",
                                                  (base / file).read_text(), re.M) is not None)
    # resolved as Sphinx does, by the text of the path: docs/examples is a link to
    # examples/, and a notebook's "../guide" means docs/guide on the site
    full = os.path.normpath(base / path)
    if any(c in path for c in "*?["):
        return bool(glob.glob(full))
    return os.path.exists(full)


def repo_pointers() -> list[tuple[str, str]]:
    """(where, path) for every repository path the prose names."""
    return [(where, p) for where, _, text in SOURCES for p in _repo_paths(text)
            if p not in CREATED_BY_THE_READER]


def test_every_repository_path_the_documentation_names_exists():
    pointers = repo_pointers()
    assert len(pointers) > 50, "the extraction found almost nothing: the patterns are broken"
    missing = [f"{where}: {path}" for where, path in pointers if not _exists(path)]
    assert not missing, "pointers to paths that are not there:\n" + "\n".join(missing)


def test_every_relative_link_resolves_from_its_file():
    missing = [f"{where}: {link}" for where, base, text in SOURCES
               for link in _relative_links(text)
               if not link.startswith(PREFIXES) and not _exists(link, base)]
    assert not missing, "links to files that are not there:\n" + "\n".join(missing)


def _readme_headings() -> set[str]:
    text = _FENCE.sub("", (ROOT / "README.md").read_text(encoding="utf-8"))
    return {m.group(1).strip() for m in re.finditer(r"^#+\s+(.+)$", text, re.M)}


def _starts_a_heading(word: str, headings: set[str]) -> bool:
    """An unquoted "the README's walkthrough" needs a heading that starts with the word."""
    return " " not in word and any(h.split()[0].lower() == word.lower() for h in headings)


def test_every_readme_section_named_is_a_heading_of_the_readme():
    headings = _readme_headings()
    named = [(where, quoted or other or word) for where, _, text in SOURCES
             for quoted, other, word in _README_SECTION.findall(text)]
    missing = [f"{where}: {name!r}" for where, name in named
               if name not in headings and not _starts_a_heading(name, headings)]
    assert not missing, (f"README sections that are not there (headings: {sorted(headings)}):\n"
                         + "\n".join(missing))


def test_paper_references_are_numbers_not_latex_labels():
    # the package's whole text: docstrings, comments and --help strings alike
    code = [(str(p.relative_to(ROOT)), p.parent, p.read_text(encoding="utf-8"))
            for p in sorted((ROOT / "dpdfit").rglob("*.py"))]
    labels = [f"{where}: {m.group(0)}" for where, _, text in SOURCES + code
              for m in _PAPER_REF.finditer(text) if not _NUMBER.match(m.group(2))]
    assert not labels, ("the paper's reader sees numbers (main text 1-5, Supplement S1-S22), "
                        "not labels:\n" + "\n".join(labels))


@pytest.mark.parametrize("text, expected", [
    ("see `datasets/synthetic_campaign` and ``dpdfit/models/``", ["datasets/synthetic_campaign",
                                                                  "dpdfit/models/"]),
    ("[mapping](examples/import/x.toml) and `results/summary.md`", ["examples/import/x.toml"]),
    ("{doc}`examples/analysis` and `benchmarks/<script name>.json`", ["benchmarks/*.json"]),
])
def test_the_extraction_finds_paths_in_code_and_links(text, expected):
    assert _repo_paths(text) == expected


def test_the_label_check_tells_labels_from_numbers():
    text = "Eq. 3, Eqs. S4-S6, Sec. S6.3 and Eq. aom-forward"
    assert [m.group(2) for m in _PAPER_REF.finditer(text)
            if not _NUMBER.match(m.group(2))] == ["aom-forward"]


def test_the_readme_check_finds_named_sections_and_parts():
    text = ('README section "Campaign folder layout", the README\'s "Measured numbers", '
            "the README's walkthrough, and the README's first command")
    named = [a or b or c for a, b, c in _README_SECTION.findall(text)]
    assert named == ["Campaign folder layout", "Measured numbers", "walkthrough"]
