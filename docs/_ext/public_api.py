"""``.. dpdfit-public-api::``: the names of ``dpdfit.__all__`` as summary tables.

The table is generated from the package, so a name added to ``dpdfit.__all__``
appears here without a second list to keep.  Each entry links to the object's
documentation in the module that defines it (the pages of the layer reference), and
shows the short name, which is how a user imports it: ``dpdfit.<name>``.
"""

from __future__ import annotations

import importlib
import inspect

from docutils import nodes
from docutils.statemachine import StringList
from sphinx.util.docutils import SphinxDirective

#: the layer an object is listed under, by the first package below ``dpdfit``
LAYERS = {
    "recordings": "Reading recordings",
    "fits": "Fits",
    "models": "Models",
    "analyses": "Analyses",
    "pipeline": "The whole analysis",
    "errors": "Errors",
}


def public_objects(package: str = "dpdfit") -> dict[str, list[str]]:
    """Group the defining location of each object of ``package.__all__`` by layer."""
    module = importlib.import_module(package)
    groups: dict[str, list[str]] = {title: [] for title in LAYERS.values()}
    for name in module.__all__:
        obj = getattr(module, name)
        if not (inspect.isclass(obj) or inspect.isfunction(obj)):
            continue
        layer = obj.__module__.split(".")[1]
        groups[LAYERS[layer]].append(f"~{obj.__module__}.{obj.__qualname__}")
    return {title: names for title, names in groups.items() if names}


class PublicApi(SphinxDirective):
    """Insert one autosummary table per layer."""

    has_content = False

    def run(self) -> list[nodes.Node]:
        lines: list[str] = []
        for title, names in public_objects().items():
            lines += [f".. rubric:: {title}", "", ".. autosummary::", ""]
            lines += [f"   {name}" for name in names]
            lines.append("")
        container = nodes.container()
        self.state.nested_parse(StringList(lines, source="dpdfit-public-api"), 0, container)
        return container.children


def setup(app):
    app.add_directive("dpdfit-public-api", PublicApi)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
