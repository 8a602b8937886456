"""Every public module, function, class, method and property of dpdfit has a docstring.

Public: a name without a leading underscore, in a module whose dotted path has no
part with one.  Functions and classes count in the module that defines them; methods
and properties in the class that defines them, where a docstring inherited from a base
class counts (:func:`inspect.getdoc`, which is what the API reference shows).  The
docstring ``dataclass`` writes for an undocumented class (its signature) does not.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
import inspect
import pkgutil

import dpdfit


def _public_modules() -> list:
    modules = [dpdfit]
    for info in pkgutil.walk_packages(dpdfit.__path__, prefix="dpdfit."):
        if not any(part.startswith("_") for part in info.name.split(".")):
            modules.append(importlib.import_module(info.name))
    return modules


MODULES = _public_modules()


def _defined_here(module) -> list:
    """The public functions and classes ``module`` defines (not those it imports)."""
    return [(name, obj) for name, obj in vars(module).items()
            if not name.startswith("_") and (inspect.isclass(obj) or inspect.isfunction(obj))
            and obj.__module__ == module.__name__]


def _own_doc(cls) -> str:
    """The class's own docstring; a dataclass's generated signature counts as none."""
    doc = cls.__dict__.get("__doc__") or ""
    if dataclasses.is_dataclass(cls) and doc.startswith(cls.__name__ + "("):
        return ""
    return doc.strip()


def _members(cls) -> list:
    """The public methods and properties ``cls`` itself defines."""
    out = []
    for name, attr in vars(cls).items():
        if name.startswith("_"):
            continue
        if isinstance(attr, (staticmethod, classmethod)):
            attr = attr.__func__
        if inspect.isfunction(attr) or isinstance(attr, (property, functools.cached_property)):
            out.append(name)
    return out


def _missing(module) -> list[str]:
    missing = []
    for name, obj in _defined_here(module):
        qual = f"{module.__name__}.{name}"
        if inspect.isfunction(obj):
            if not (inspect.getdoc(obj) or "").strip():
                missing.append(qual)
            continue
        if not _own_doc(obj):
            missing.append(qual)
        for member in _members(obj):
            if not (inspect.getdoc(getattr(obj, member)) or "").strip():
                missing.append(f"{qual}.{member}")
    return missing


def test_every_public_module_has_a_docstring():
    missing = [m.__name__ for m in MODULES if not (m.__doc__ or "").strip()]
    assert not missing, "modules without a docstring:\n  " + "\n  ".join(missing)


def test_every_public_function_class_method_and_property_has_a_docstring():
    missing = [name for m in MODULES for name in _missing(m)]
    assert not missing, (f"{len(missing)} public objects without a docstring:\n  "
                         + "\n  ".join(missing))


def test_the_walk_reaches_every_layer_and_skips_private_modules():
    """The walk is not vacuous: it finds the layers' modules and their classes' members,
    and it leaves out private modules."""
    names = {m.__name__ for m in MODULES}
    for layer in ("core", "recordings", "fits", "models", "analyses", "simulation",
                  "report", "pipeline", "cli"):
        assert f"dpdfit.{layer}" in names
    assert "dpdfit.analyses.diagnosis.effects.base" in names
    assert not [n for n in names if any(p.startswith("_") for p in n.split("."))]
    from dpdfit.fits.calibration.amplitude import AmplitudeCalibration
    assert {"order", "from_dict", "y"} <= set(_members(AmplitudeCalibration))
