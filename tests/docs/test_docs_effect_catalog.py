"""The documentation's catalog of effects is generated from the registry: its tables have
one row per registered effect (and per parameter), in registry order, and an effect
registered later appears without any other change.  Needs no Sphinx build."""

from __future__ import annotations

import importlib.util

import pytest
from docutils import nodes

from dpdfit.analyses.diagnosis.effects import EFFECTS, register, unregister
from tests.helpers.paths import ROOT

EXTENSION = ROOT / "docs" / "_ext" / "effect_catalog.py"


@pytest.fixture(scope="module")
def catalog():
    spec = importlib.util.spec_from_file_location("effect_catalog", EXTENSION)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _table(catalog, which: str) -> nodes.table:
    header, rows = catalog.ROWS[which]()
    assert all(len(r) == len(header) for r in rows)
    return catalog.build_table(header, rows)


@pytest.mark.parametrize("which", ["effects", "injection"])
def test_catalog_table_rows_are_the_registry_s_effects(catalog, which):
    assert catalog.table_effect_names(_table(catalog, which)) == list(EFFECTS)


def test_catalog_parameter_rows_are_every_parameter_of_every_family(catalog):
    body = next(iter(_table(catalog, "parameters").findall(nodes.tbody)))
    keys = [row.children[1].astext() for row in body.children]
    assert keys == [e.key(p.name) for e in EFFECTS.values() for p in e.parameters()]


def test_catalog_table_lists_an_effect_registered_later(catalog):
    from tests.helpers.seventh_order_effect import EFFECT
    register(EFFECT)
    try:
        names = catalog.table_effect_names(_table(catalog, "effects"))
        assert names == list(EFFECTS) and names[-1] == EFFECT.name
    finally:
        unregister(EFFECT.name)
    assert EFFECT.name not in catalog.table_effect_names(_table(catalog, "effects"))


def test_catalog_directive_is_registered_parallel_safe(catalog):
    added = {}

    class App:
        def add_directive(self, name, cls):
            added[name] = cls

    meta = catalog.setup(App())
    assert set(added) == {"effect-catalog"}
    assert meta["parallel_read_safe"] and meta["parallel_write_safe"]
