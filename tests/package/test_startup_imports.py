"""A command starts at once: ``import dpdfit`` and ``--help`` load none of the work.

``import dpdfit`` re-exports the public API lazily (its module ``__getattr__``), and the
command line registers only the command it runs, whose module imports the library when
the command runs.  Each check runs a fresh interpreter and reads which modules it
loaded; the help texts are pinned in ``tests/golden/`` (they did not change when the
imports moved).  How long a start takes is measured by ``benchmarks/startup.py``, not
asserted here.
"""

from __future__ import annotations

import ast
import importlib
import json
import os
import subprocess
import sys

import dpdfit
from dpdfit.cli.main import COMMANDS
from tests.helpers.golden import check_golden
from tests.helpers.paths import ROOT

#: what neither ``import dpdfit`` nor any ``--help`` may load: the heavy libraries and
#: the layers that do the work (a command loads them when it runs)
NOT_AT_START = ("scipy", "pandas", "matplotlib", "numba", "dpdfit.fits", "dpdfit.models",
                "dpdfit.analyses", "dpdfit.simulation", "dpdfit.report", "dpdfit.pipeline")
#: the one command whose options need the work: ``simulate-campaign --help`` lists the
#: effects it can conceal, read from the diagnosis's effect registry
NEEDS_THE_REGISTRY = "simulate-campaign"

#: a fresh interpreter: every command's ``--help`` through :func:`dpdfit.cli.main.main`,
#: then the modules loaded, then ``simulate-campaign --help``
_EVERY_COMMAND_HELP = f"""
import contextlib, io, json, sys
from dpdfit.cli.main import COMMANDS, main

def help_of(name):
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main([name, "--help"]) == 0
    return out.getvalue()

texts = {{name: help_of(name) for name in COMMANDS if name != {NEEDS_THE_REGISTRY!r}}}
modules = sorted(sys.modules)
texts[{NEEDS_THE_REGISTRY!r}] = help_of({NEEDS_THE_REGISTRY!r})
print(json.dumps({{"modules": modules, "help": [texts[name] for name in COMMANDS]}}))
"""


def _python(*args: str) -> subprocess.CompletedProcess:
    """``python ARGS`` in a fresh interpreter at the repository's root, 80 columns wide."""
    run = subprocess.run([sys.executable, *args], cwd=ROOT, capture_output=True, text=True,
                         env={**os.environ, "COLUMNS": "80"}, timeout=120)
    assert run.returncode == 0, run.stderr[-3000:]
    return run


def _work_loaded(modules) -> list[str]:
    return sorted(m for m in modules
                  if any(m == name or m.startswith(name + ".") for name in NOT_AT_START))


def test_import_dpdfit_loads_none_of_the_work():
    run = _python("-c", "import dpdfit; import sys; print(sorted(m for m in sys.modules))")
    modules = ast.literal_eval(run.stdout)
    assert "dpdfit" in modules
    assert _work_loaded(modules) == []


def test_a_public_name_loads_its_module_when_used():
    """``dpdfit.polyfit`` imports the polynomial fit then, not the rest of the API;
    ``from dpdfit import Analysis`` the pipeline."""
    run = _python("-c", "import dpdfit, sys; dpdfit.polyfit; print(sorted(sys.modules)); "
                        "from dpdfit import Analysis; print(sorted(sys.modules))")
    after_polyfit, after_analysis = map(ast.literal_eval, run.stdout.splitlines())
    assert "dpdfit.fits.polyfit" in after_polyfit
    assert "dpdfit.pipeline" not in after_polyfit
    assert "dpdfit.pipeline.analyze" in after_analysis


def test_every_public_name_is_what_type_checkers_read():
    """Each name ``dpdfit/__init__.py`` imports for type checkers (under
    ``TYPE_CHECKING``) is, at run time, the object defined where they look it up; every
    public name is listed by ``dir`` and taken by ``from dpdfit import *``."""
    imported = {}
    for node in ast.walk(ast.parse((ROOT / "dpdfit" / "__init__.py").read_text())):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("dpdfit"):
            imported.update({a.asname or a.name: node.module for a in node.names})
    for name, module in imported.items():
        assert getattr(dpdfit, name) is getattr(importlib.import_module(module), name), name
    assert set(dpdfit.__all__) <= set(dir(dpdfit))
    namespace: dict = {}
    exec("from dpdfit import *", namespace)
    assert set(dpdfit.__all__) <= set(namespace)


def test_dpdfit_help_loads_none_of_the_work_and_is_unchanged():
    """``python -m dpdfit --help``, its imports read from ``-X importtime``."""
    run = _python("-X", "importtime", "-m", "dpdfit", "--help")
    modules = [line.rpartition("|")[2].strip() for line in run.stderr.splitlines()
               if line.startswith("import time:")]
    assert "dpdfit.cli.main" in modules
    assert _work_loaded(modules) == []
    assert not [m for m in modules if m.startswith("dpdfit.cli.") and m not in (
        "dpdfit.cli.main", "dpdfit.cli.help_texts", "dpdfit.cli.logs")], modules
    check_golden("cli_help.txt", "$ dpdfit --help\n" + run.stdout)


def test_every_command_help_loads_none_of_the_work_and_is_unchanged():
    """``dpdfit CMD --help`` of every command, in one fresh interpreter."""
    out = json.loads(_python("-c", _EVERY_COMMAND_HELP).stdout)
    assert {f"dpdfit.cli.{m.rpartition('.')[2]}" for m in COMMANDS.values()} <= set(
        out["modules"])
    assert _work_loaded(out["modules"]) == []
    check_golden("cli_command_help.txt", "".join(
        f"$ dpdfit {name} --help\n{text}" for name, text in zip(COMMANDS, out["help"])))
