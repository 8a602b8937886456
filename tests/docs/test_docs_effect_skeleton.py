"""The effect skeleton on ``docs/diagnosis/adding-an-effect.md`` is a working effect.

The page's snippets that edit the package are not run by the docs tests (they would
change the package); this test runs the skeleton's two modules (the effect and its
injection) as modules of their own instead, registers their ``EFFECT`` and
``INJECTION`` at run time (as a lab's own effect is) and checks what the page's "Right
away" check prints: its forms, and that it is a default hypothesis and an effect the
simulator takes.  Its physics is checked on one field.
"""

import sys
import types

import numpy as np
import pytest

from dpdfit.analyses.diagnosis.effects import EFFECTS, default_effects
from dpdfit.simulation.campaign.config import SIMULATOR_EFFECTS
from tests.helpers.doc_snippets import DOCS, blocks
from tests.helpers.registered_effect import registered_effect

PAGE = DOCS / "diagnosis" / "adding-an-effect.md"


def _skeleton_code(defines: str = "EFFECT = ") -> str:
    (block,) = [b for b in blocks(PAGE) if b.lang == "python" and defines in b.text]
    return block.text


def _page_module(package: str, defines: str, monkeypatch) -> types.ModuleType:
    """The page's module that ``defines`` a name, run as ``package.third_order_pm`` (its
    imports are relative) without writing it into the package."""
    module = types.ModuleType(f"{package}.third_order_pm")
    module.__package__ = package
    monkeypatch.setitem(sys.modules, module.__name__, module)
    exec(compile(_skeleton_code(defines), str(PAGE), "exec"), module.__dict__)
    return module


@pytest.fixture
def skeleton_effect(monkeypatch):
    # run as the page's files would run: the effect, then its injection, which imports it
    effect = _page_module("dpdfit.analyses.diagnosis.effects", "EFFECT = ", monkeypatch).EFFECT
    injection = _page_module("dpdfit.simulation.injections", "INJECTION = ",
                             monkeypatch).INJECTION
    with registered_effect(effect, injection):
        yield injection


def test_the_pages_effect_skeleton_registers_and_is_a_hypothesis(skeleton_effect):
    name = skeleton_effect.name
    assert name == "third_order_pm"
    assert EFFECTS[name].forms_for()            # the page's first check prints these
    assert name in default_effects() and name in SIMULATOR_EFFECTS


def test_the_pages_effect_skeleton_injects_the_phase_it_describes(skeleton_effect):
    y = np.linspace(0.0, 0.5, 11).astype(complex)
    y_full = 0.5
    phi4 = 0.2
    out = skeleton_effect.inject_field({"phi4": phi4}, y, None, 1e9, y_full)
    np.testing.assert_allclose(np.abs(out), np.abs(y), atol=1e-15)
    # the phase phi4 r^4 with r = |y| / y(1): phi4 at full drive
    np.testing.assert_allclose(np.angle(out[1:]), phi4 * (np.abs(y[1:]) / y_full) ** 4,
                               atol=1e-12)
