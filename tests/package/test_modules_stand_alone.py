"""Test modules and benchmarks stand alone: no test module imports another, no benchmark
imports from ``tests/``.

What several test modules share lives in ``tests/helpers/`` (or is a fixture of
``tests/conftest.py``); what a benchmark shares with the tests lives in the package
(the truth AOM's polynomial form, the simulated gate points and the polyfit problems
are in :mod:`dpdfit.simulation`), so that neither imports from the other.  Read from
the source with :mod:`ast`, imports inside functions included.
"""

from __future__ import annotations

import ast

import pytest

from tests.helpers.paths import ROOT, TESTS

TEST_MODULES = sorted(TESTS.rglob("test_*.py"))
#: modules of tests/ that are not test modules: they must not reach a test module either
SUPPORT = sorted([*TESTS.rglob("conftest.py"), *(TESTS / "helpers").glob("*.py")])
BENCHMARKS = sorted((ROOT / "benchmarks").glob("*.py"))
IMPORTERS = {"import_module", "__import__"}       # importlib.import_module("..."), __import__


def imported(source: str) -> set[str]:
    """Dotted names a module's source imports: ``import a.b`` gives ``a.b``, ``from a
    import b`` gives ``a`` and ``a.b``, ``from . import b`` gives ``.b``, and a literal
    ``importlib.import_module("a.b")`` gives ``a.b``."""
    names = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = "." * node.level + (node.module or "")
            if node.module:
                names.add(base)
            sep = "" if base.endswith(".") else "."
            names.update(base + sep + a.name for a in node.names)
        elif isinstance(node, ast.Call) and node.args \
                and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str):
            func = node.func
            name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            if name in IMPORTERS:
                names.add(node.args[0].value)
    return names


def _test_modules_in(names: set[str]) -> list[str]:
    """The names that are a test module: ``tests.test_x``, ``test_x``, ``.test_x``
    (or something inside one)."""
    def is_test_module(name: str) -> bool:
        parts = name.lstrip(".").split(".")
        return parts[0].startswith("test_") or (
            parts[0] == "tests" and len(parts) > 1 and parts[1].startswith("test_"))
    return sorted(n for n in names if is_test_module(n))


def _from_tests(names: set[str]) -> list[str]:
    return sorted(n for n in names if n == "tests" or n.startswith("tests."))


@pytest.mark.parametrize("path", TEST_MODULES + SUPPORT, ids=lambda p: p.name)
def test_no_test_module_imports_another(path):
    found = _test_modules_in(imported(path.read_text()))
    assert not found, (f"{path.relative_to(ROOT)} imports test module(s) {found}: move what "
                       "they share to tests/helpers/ or a conftest.py fixture")


@pytest.mark.parametrize("path", BENCHMARKS, ids=lambda p: p.name)
def test_no_benchmark_imports_from_tests(path):
    found = _from_tests(imported(path.read_text()))
    assert not found, (f"{path.relative_to(ROOT)} imports {found} from tests/: a helper it "
                       "shares with the tests belongs in the package")


@pytest.mark.parametrize("source, test_module, from_tests", [
    ("from tests.test_cli import run", True, True),
    ("import tests.test_transfer", True, True),
    ("from tests import test_properties", True, True),
    ("from .test_display import AOM", True, False),
    ("from . import test_display", True, False),
    ("import test_polyfit", True, False),
    ("def f():\n    from tests.test_alignment import simulated_gate", True, True),
    ("importlib.import_module('tests.test_cli')", True, True),
    ("from tests.helpers.cli_run import run", False, True),
    ("from tests.helpers import prop_mutations", False, True),
    ("from benchmarks.truth_model import truth_poly_tf", False, False),
    ("from dpdfit.cli.main import main", False, False),
])
def test_the_rules_see_every_spelling(source, test_module, from_tests):
    names = imported(source)
    assert bool(_test_modules_in(names)) is test_module, names
    assert bool(_from_tests(names)) is from_tests, names
