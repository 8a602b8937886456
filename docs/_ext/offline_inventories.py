"""Intersphinx links that work on an offline build machine.

Intersphinx fetches each project's ``objects.inv`` from the web.  The machines that
build this site (CI included) may have no network, and a failed fetch is a warning,
which ``-W`` turns into a failed build.  This extension writes, for each linked
project, a small inventory of the objects dpdfit's documentation names (the types in
its signatures and the functions its pages cite) and lists it as the fallback
location after the project's own inventory: online builds get the full inventory,
offline builds these entries.  The addresses follow each site's page layout (e.g.
numpy's ``reference/generated/<name>.html``); ``tests/docs/test_docs_sources.py`` checks
the inventories are well formed.
"""

from __future__ import annotations

import zlib
from pathlib import Path

#: project -> [(object name, sphinx role, page relative to the project's root)]
OBJECTS: dict[str, list[tuple[str, str, str]]] = {
    "python": [
        (name, "py:class", f"library/functions.html#{name}")
        for name in ("int", "float", "bool", "str", "dict", "list", "tuple", "object", "bytes")
    ] + [
        ("pathlib.Path", "py:class", "library/pathlib.html#pathlib.Path"),
        ("os.PathLike", "py:class", "library/os.html#os.PathLike"),
        ("collections.abc.Mapping", "py:class",
         "library/collections.abc.html#collections.abc.Mapping"),
        ("collections.abc.Sequence", "py:class",
         "library/collections.abc.html#collections.abc.Sequence"),
        ("collections.abc.Iterable", "py:class",
         "library/collections.abc.html#collections.abc.Iterable"),
        ("collections.abc.Callable", "py:class",
         "library/collections.abc.html#collections.abc.Callable"),
        ("typing.Any", "py:data", "library/typing.html#typing.Any"),
        ("logging.Logger", "py:class", "library/logging.html#logging.Logger"),
        ("datetime.datetime", "py:class", "library/datetime.html#datetime.datetime"),
        ("ValueError", "py:exception", "library/exceptions.html#ValueError"),
        ("tomllib", "py:module", "library/tomllib.html#module-tomllib"),
    ],
    "numpy": [
        ("numpy.ndarray", "py:class", "reference/generated/numpy.ndarray.html#numpy.ndarray"),
        ("numpy.random.Generator", "py:class",
         "reference/random/generator.html#numpy.random.Generator"),
        ("numpy.random.default_rng", "py:function",
         "reference/random/generator.html#numpy.random.default_rng"),
        ("numpy.typing.ArrayLike", "py:data", "reference/typing.html#numpy.typing.ArrayLike"),
        ("numpy.polynomial.polynomial.polyval", "py:function",
         "reference/generated/numpy.polynomial.polynomial.polyval.html"
         "#numpy.polynomial.polynomial.polyval"),
    ],
    "scipy": [
        (f"scipy.{name}", role, f"reference/generated/scipy.{name}.html#scipy.{name}")
        for name, role in (
            ("optimize.least_squares", "py:function"),
            ("optimize.minimize", "py:function"),
            ("optimize.OptimizeResult", "py:class"),
            ("signal.periodogram", "py:function"),
            ("signal.welch", "py:function"),
            ("fft.rfft", "py:function"),
            ("linalg.solve_triangular", "py:function"),
            ("integrate.solve_ivp", "py:function"),
            ("integrate.DOP853", "py:class"),
            ("stats.chi2", "py:data"),
            ("stats.binom", "py:data"),
            ("stats.beta", "py:data"),
        )
    ],
    "pandas": [
        (alias, "py:class", f"reference/api/pandas.{name}.html#pandas.{name}")
        for name in ("DataFrame", "Series")
        for alias in (f"pandas.{name}", f"pandas.core.{'frame' if name == 'DataFrame' else 'series'}.{name}")
    ] + [
        ("pandas.read_csv", "py:function", "reference/api/pandas.read_csv.html#pandas.read_csv"),
    ],
    "matplotlib": [
        ("matplotlib.figure.Figure", "py:class",
         "api/_as_gen/matplotlib.figure.Figure.html#matplotlib.figure.Figure"),
        ("matplotlib.axes.Axes", "py:class",
         "api/_as_gen/matplotlib.axes.Axes.html#matplotlib.axes.Axes"),
        ("matplotlib.axes._axes.Axes", "py:class",
         "api/_as_gen/matplotlib.axes.Axes.html#matplotlib.axes.Axes"),
    ],
    "emcee": [
        ("emcee.EnsembleSampler", "py:class", "user/sampler/#emcee.EnsembleSampler"),
        ("emcee.autocorr.integrated_time", "py:function",
         "user/autocorr/#emcee.autocorr.integrated_time"),
        ("emcee.moves.StretchMove", "py:class", "user/moves/#emcee.moves.StretchMove"),
    ],
    "lmfit": [
        (alias, "py:class", "parameters.html#lmfit.parameter.Parameters")
        for alias in ("lmfit.parameter.Parameters", "lmfit.Parameters")
    ] + [
        (alias, "py:class", "parameters.html#lmfit.parameter.Parameter")
        for alias in ("lmfit.parameter.Parameter", "lmfit.Parameter")
    ] + [
        ("lmfit.printfuncs.fit_report", "py:function",
         "fitting.html#lmfit.printfuncs.fit_report"),
    ],
}


def write_inventory(path: Path, project: str, version: str,
                    objects: list[tuple[str, str, str]]) -> Path:
    """Write a Sphinx version-2 inventory (the ``objects.inv`` format) to *path*."""
    header = (f"# Sphinx inventory version 2\n# Project: {project}\n# Version: {version}\n"
              "# The remainder of this file is compressed using zlib.\n").encode()
    body = "".join(f"{name} {role} 1 {uri} -\n" for name, role, uri in objects).encode()
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(header + zlib.compress(body))
    return path


def with_offline_fallback(mapping: dict, directory: Path) -> dict:
    """Return *mapping* with a local inventory as each project's second location."""
    out = {}
    for key, (uri, inventory) in mapping.items():
        local = write_inventory(directory / f"{key}.inv", key, "offline",
                                OBJECTS.get(key, []))
        out[key] = (uri, (inventory, str(local)))
    return out
