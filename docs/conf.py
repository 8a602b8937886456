"""Sphinx configuration of the dpdfit documentation.

Build (warnings are errors)::

    pip install ".[docs]"
    python -m sphinx -W --keep-going -b html docs docs/_build/html

The notebooks in ``examples/`` are executed on every build (myst-nb).  For a quick
look while writing prose, ``DPDFIT_DOCS_EXECUTE=off`` skips the execution; the
build of record (CI) never sets it.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))

import dpdfit  # noqa: E402
from offline_inventories import with_offline_fallback  # noqa: E402

project = "dpdfit"
author = "the dpdfit developers"
copyright = "2026, the dpdfit developers"
release = dpdfit.__version__
version = ".".join(release.split(".")[:2])

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.intersphinx",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "sphinxarg.ext",
    "cli_examples",
    "myst_nb",
    "sphinx_copybutton",
    "benchmark_tables",
    "benchmark_values",
    "effect_catalog",
    "public_api",
]

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
root_doc = "index"
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "**.ipynb_checkpoints",
                    "examples/import", "examples/*.md"]
# DPDFIT_DOCS_API=off leaves the API reference out (a build of the prose pages in
# seconds while writing them); the build of record never sets it
if os.environ.get("DPDFIT_DOCS_API") == "off":
    exclude_patterns += ["reference/api.md", "reference/modules.md", "reference/generated"]
templates_path = ["_templates"]

# -- MyST / notebooks --------------------------------------------------------
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3
nb_execution_mode = "off" if os.environ.get("DPDFIT_DOCS_EXECUTE") == "off" else "force"
nb_execution_timeout = 900
nb_execution_raise_on_error = True      # a failing cell fails the build
nb_execution_show_tb = True
nb_merge_streams = True

# -- API reference -----------------------------------------------------------
autosummary_generate = True
autosummary_imported_members = False
# ignore-module-all: a package's __all__ re-exports objects documented in the module
# that defines them; documenting them twice would make every cross-reference ambiguous
autodoc_default_options = {"members": True, "show-inheritance": True, "ignore-module-all": True}
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_typehints_format = "short"
autoclass_content = "class"
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_rtype = False
napoleon_preprocess_types = True

# Links into the libraries dpdfit builds on.  The build machine may be offline, so
# each inventory falls back to a small local one (docs/_ext/offline_inventories.py)
# when the project's own objects.inv cannot be fetched.
intersphinx_mapping = {
    "python": ("https://docs.python.org/3/", None),
    "numpy": ("https://numpy.org/doc/stable/", None),
    "scipy": ("https://docs.scipy.org/doc/scipy/", None),
    "pandas": ("https://pandas.pydata.org/docs/", None),
    "matplotlib": ("https://matplotlib.org/stable/", None),
    "emcee": ("https://emcee.readthedocs.io/en/stable/", None),
    "lmfit": ("https://lmfit.github.io/lmfit-py/", None),
}
intersphinx_timeout = 5
intersphinx_mapping = with_offline_fallback(intersphinx_mapping, HERE / "_build" / "inventories")

# -- HTML ---------------------------------------------------------------------
html_theme = "furo"
html_title = f"dpdfit {release}"
html_static_path = ["_static"]


# napoleon reads the text before a colon on the first line of an attribute's or a
# property's docstring as its type ("one line: what is missing" -> type "one line",
# cross-referenced).  dpdfit's attribute and property docstrings are prose (the types
# come from the annotations), so they are given back as written after napoleon ran.
_PROSE_DOCSTRINGS: dict = {}


def _keep_prose(app, what, name, obj, options, lines):
    if what in ("attribute", "data", "property"):
        _PROSE_DOCSTRINGS[name] = list(lines)


def _restore_prose(app, what, name, obj, options, lines):
    if what in ("attribute", "data", "property") and name in _PROSE_DOCSTRINGS:
        lines[:] = _PROSE_DOCSTRINGS.pop(name)


def setup(app):
    app.connect("autodoc-process-docstring", _keep_prose, priority=400)    # napoleon: 500
    app.connect("autodoc-process-docstring", _restore_prose, priority=600)
