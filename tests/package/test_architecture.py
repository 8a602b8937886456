"""The package's structure: layers, `__all__`, private names, import circles, plotting at
the edge.

The layer contract itself is import-linter's (``[tool.importlinter]`` in pyproject.toml);
the other rules are read from the source with :mod:`ast`, counting imports inside functions
as well as those at the top.
"""

from __future__ import annotations

import ast
import importlib
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

import dpdfit
from tests.helpers.paths import ROOT

PKG = Path(dpdfit.__file__).resolve().parent
MODULES = sorted(PKG.rglob("*.py"))
#: top-level folders of dpdfit, lowest layer first (the import-linter contract)
LAYERS = ["core", "recordings", "fits", "models", "analyses", "simulation", "report",
          "pipeline", "cli"]


def _name(path: Path) -> str:
    rel = path.relative_to(PKG.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _layer(module: str) -> str | None:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and parts[1] in LAYERS else None


def _tree(path: Path) -> ast.Module:
    return ast.parse(path.read_text(), filename=str(path))


def _absolute(node: ast.ImportFrom, module: str, is_pkg: bool) -> str:
    if node.level == 0:
        return node.module or ""
    base = module.split(".")
    base = base if is_pkg else base[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _imports(path: Path):
    """``(node, source, names)`` of every import of a dpdfit module in ``path``, inside
    functions too: ``source`` the absolute module imported from (``import a.b``: ``a.b``,
    with ``names`` empty), ``names`` what ``from source import ...`` takes."""
    module = _name(path)
    for node in ast.walk(_tree(path)):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "dpdfit":
                    yield node, alias.name, []
        elif isinstance(node, ast.ImportFrom):
            source = _absolute(node, module, path.name == "__init__.py")
            if source.split(".")[0] == "dpdfit":
                yield node, source, [a.name for a in node.names]


def _imported_modules(path: Path, modules: set) -> set:
    """The dpdfit modules ``path`` imports: ``from pkg import sub`` counts as importing the
    module ``pkg.sub``, a name that is not a module as importing its module."""
    out = set()
    for _, source, names in _imports(path):
        targets = [f"{source}.{n}" if f"{source}.{n}" in modules else source for n in names]
        for target in targets or [source]:
            while target not in modules and "." in target:
                target = target.rpartition(".")[0]
            out.add(target)
    return out


@pytest.mark.skipif(shutil.which("lint-imports") is None, reason="import-linter not installed")
def test_import_contracts_hold():
    """Each layer imports only from the layers below it; matplotlib only in dpdfit.report."""
    run = subprocess.run(["lint-imports", "--config", str(ROOT / "pyproject.toml")],
                         cwd=ROOT, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-2000:]
    assert "broken" in run.stdout and "0 broken" in run.stdout


@pytest.mark.parametrize("path", MODULES, ids=lambda p: _name(p))
def test_all_is_in_sync(path):
    """``__all__`` names exactly the public functions, classes and constants a module defines
    (plus, in a package's ``__init__``, what it re-exports), and every name in it exists."""
    module = _name(path)
    mod = importlib.import_module(module)
    assert hasattr(mod, "__all__"), f"{module} has no __all__"
    missing = [n for n in mod.__all__ if not hasattr(mod, n)]
    assert not missing, f"{module}.__all__ names undefined {missing}"
    assert len(set(mod.__all__)) == len(mod.__all__), f"{module}.__all__ has duplicates"
    defined = set()
    for node in _tree(path).body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            defined.add(node.name)
        elif isinstance(node, ast.Assign):
            defined |= {t.id for t in node.targets if isinstance(t, ast.Name)}
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            defined.add(node.target.id)
    public = {n for n in defined if not n.startswith("_") and n != "log"}
    unlisted = sorted(public - set(mod.__all__))
    assert not unlisted, f"{module} defines public names not in __all__: {unlisted}"


def test_top_level_exports_every_name_it_imports():
    """``dpdfit.__all__`` lists every name the package's ``__init__`` imports from dpdfit
    for users, those it re-exports lazily (imported under ``TYPE_CHECKING``) included."""
    imported = set()
    for node in ast.walk(_tree(PKG / "__init__.py")):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("dpdfit"):
            imported |= {a.asname or a.name for a in node.names}
    assert imported == set(dpdfit.__all__), sorted(imported ^ set(dpdfit.__all__))


def test_no_private_name_crosses_a_layer():
    """A name with a leading underscore is imported only within its own top-level folder."""
    bad = []
    for path in MODULES:
        module = _name(path)
        for node in ast.walk(_tree(path)):
            if not isinstance(node, ast.ImportFrom):
                continue
            source = _absolute(node, module, path.name == "__init__.py")
            if not source.startswith("dpdfit"):
                continue
            if _layer(source) == _layer(module):
                continue
            names = [a.name for a in node.names]
            private = [n for n in names if n.startswith("_") and not n.startswith("__")]
            private += [source] if any(p.startswith("_") for p in source.split(".")[1:]) else []
            if private:
                bad.append(f"{module} imports {private} from {source}")
    assert not bad, "\n".join(bad)


def test_matplotlib_only_in_report():
    """No module outside dpdfit.report imports matplotlib, even inside a function."""
    bad = []
    for path in MODULES:
        module = _name(path)
        if _layer(module) == "report":
            continue
        for node in ast.walk(_tree(path)):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            if any(n.split(".")[0] == "matplotlib" for n in names):
                bad.append(module)
    assert not bad, bad


def test_functions_are_readable_in_one_sitting():
    """No function over 80 lines (a module is as long as its one concept needs)."""
    long_functions = [(_name(p), f.name, f.end_lineno - f.lineno + 1) for p in MODULES
                      for f in ast.walk(_tree(p))
                      if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef))
                      and f.end_lineno - f.lineno + 1 > 80]
    assert not long_functions, long_functions


def test_no_private_name_is_imported_from_another_module():
    """A name with a leading underscore is used only in the module that defines it: no
    ``from X import _name`` between two dpdfit modules (a package's ``__init__`` and its
    submodules are different modules), and no module whose own name starts with ``_`` is
    imported.  What another module needs is a public name of the module it belongs to."""
    bad = []
    for path in MODULES:
        module = _name(path)
        for node, source, names in _imports(path):
            where = f"{module}:{node.lineno}"
            private = [n for n in names if _private(n)] if source != module else []
            if any(_private(part) for part in source.split(".")):
                bad.append(f"{where} imports the private module {source}")
            elif private:
                bad.append(f"{where} imports {', '.join(private)} from {source}")
    assert not bad, "\n".join(bad)


def test_no_import_circle():
    """The imports between dpdfit modules (inside functions too) form no circle: every
    strongly connected component of the import graph is a single module."""
    names = [_name(p) for p in MODULES]
    index = {n: i for i, n in enumerate(names)}
    edges = [(index[_name(p)], index[t]) for p in MODULES
             for t in _imported_modules(p, set(index)) if t != _name(p)]
    rows, cols = zip(*edges)
    graph = coo_matrix((np.ones(len(edges)), (rows, cols)), shape=(len(names), len(names)))
    _, label = connected_components(graph, directed=True, connection="strong")
    circles = [sorted(n for n, k in zip(names, label) if k == c)
               for c in np.unique(label) if np.count_nonzero(label == c) > 1]
    assert not circles, "\n".join(" <-> ".join(c) for c in circles)
