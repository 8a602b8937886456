"""The README stays one screen with the two commands, and the documentation's sources hold together.

The site itself is built with warnings as errors by ``.ci/run`` after the tests; these
checks need no Sphinx and run in a second.
"""

from __future__ import annotations

import importlib.util
import re
import zlib
from pathlib import Path

from tests.helpers.paths import ROOT

DOCS = ROOT / "docs"

INSTALL_AND_ANALYZE = ("python3 -m venv .venv && . .venv/bin/activate && pip install . "
                       "&& dpdfit analyze datasets/synthetic_campaign -o results")
INSTALL_AND_TEST = ('python3 -m venv .venv && . .venv/bin/activate && pip install ".[test]" '
                    "&& python -m pytest -n 2")


def _load_extension(name: str):
    spec = importlib.util.spec_from_file_location(name, DOCS / "_ext" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_readme_is_one_screen_with_the_two_commands_near_the_top():
    lines = (ROOT / "README.md").read_text().splitlines()
    assert len(lines) <= 200, f"README.md has {len(lines)} lines"
    first = [i for i, line in enumerate(lines) if line.strip() == INSTALL_AND_ANALYZE]
    second = [i for i, line in enumerate(lines) if line.strip() == INSTALL_AND_TEST]
    assert first and second, "README.md must show the two commands verbatim"
    assert first[0] < 60 and second[0] < 60


def test_ci_runs_the_readme_test_command_and_builds_the_docs_with_warnings_as_errors():
    ci = (ROOT / ".ci" / "run").read_text()
    assert INSTALL_AND_TEST in ci
    readme = (ROOT / "README.md").read_text()
    build = re.search(r"python -m sphinx [^\n`]+", readme).group(0).strip()
    assert build in ci and " -W " in build and "--keep-going" in build


def test_every_page_in_a_toctree_exists():
    missing = []
    for page in DOCS.rglob("*.md"):
        if "_build" in page.parts or page.is_relative_to(DOCS / "examples"):
            continue
        for block in re.findall(r"```\{toctree\}\n(.*?)```", page.read_text(), re.S):
            for entry in block.splitlines():
                entry = entry.strip()
                if not entry or entry.startswith(":"):
                    continue
                target = page.parent / entry
                if not any(target.with_suffix(s).exists() for s in (".md", ".ipynb", ".rst")):
                    missing.append(f"{page.relative_to(DOCS)}: {entry}")
    assert not missing, missing


def test_offline_inventories_are_sphinx_version_2_files(tmp_path):
    inventories = _load_extension("offline_inventories")
    mapping = inventories.with_offline_fallback(
        {"numpy": ("https://numpy.org/doc/stable/", None)}, tmp_path)
    uri, (first, local) = mapping["numpy"]
    assert uri == "https://numpy.org/doc/stable/" and first is None
    raw = Path(local).read_bytes()
    header = raw.split(b"\n", 4)
    assert header[0] == b"# Sphinx inventory version 2"
    entries = zlib.decompress(header[4]).decode().splitlines()
    names = {line.split()[0] for line in entries}
    assert "numpy.ndarray" in names
    for line in entries:
        name, role, priority, location, display = line.split(" ")
        assert role.count(":") == 1 and priority == "1" and display == "-"
        assert "#" in location and not location.startswith("/")


def test_example_notebooks_are_committed_without_outputs():
    import nbformat

    for path in sorted((ROOT / "examples").glob("*.ipynb")):
        nb = nbformat.read(path, as_version=4)
        for cell in nb.cells:
            if cell.cell_type == "code":
                assert not cell.outputs and cell.execution_count is None, path.name
