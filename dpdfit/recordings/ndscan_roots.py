"""The ndscan roots of a results file: each root's schema, axes and channels.

ndscan (``ndscan/experiment/entry_point.py``) writes a root's schema as JSON,
``<root>axes`` (a list: each axis's parameter, with its ``fqn``, ``type`` and
``spec``: ``unit``, ``scale``) and ``<root>channels`` (an object: each result
channel's ``type``, ``unit``, ``scale``), and each point's values in
``<root>points.axis_<i>`` and ``<root>points.channel_<name>``.  :func:`read_scan`
reads the schema and the axes of one root when its scan is first used, and a
channel only when it is used; a schema of the wrong shape (a list where ndscan
writes an object, an entry that is not an object, a unit that is not text) is
one InputError naming the file, the root and the dataset.
"""

from __future__ import annotations

import json

import numpy as np

from dpdfit.core.jsonable import json_kind
from dpdfit.errors import InputError

from .hdf5_contents import ResultsFileContents, one_value, short_repr
from .lazy_mapping import LazyMapping
from .ndscan_scan import NdscanScan, Quantity, spec_scale

__all__ = ["find_ndscan_roots", "read_scan"]

_SCHEMA_KEY = "ndscan_schema_revision"

def _json(datasets, key: str, name: str, kind: type):
    """The JSON value of dataset ``key``: a list or an object (``kind``), as ndscan writes."""
    if key not in datasets:
        raise InputError(f"dataset '{key}' missing", file=name)
    try:
        value = json.loads(one_value(datasets[key][0], key, name))
    except (TypeError, ValueError, RecursionError) as exc:
        raise InputError(f"dataset '{key}' is not JSON ({exc})", file=name) from None
    if not isinstance(value, kind):
        raise InputError(f"dataset '{key}' is a JSON {json_kind(value)} where ndscan writes "
                         f"{'a list' if kind is list else 'an object'}", file=name)
    return value


def _entry(value, where: str, name: str, key: str | None = None) -> dict:
    """``value`` (or its ``key``), which the ndscan schema has as a JSON object."""
    if key is not None:
        value, where = value.get(key, {}), f"{where} '{key}'"
    if not isinstance(value, dict):
        raise InputError(f"{where} is a JSON {json_kind(value)}, not an object", file=name)
    return value


def _fields(spec: dict, kind, description, where: str, name: str) -> dict:
    """The checked unit, scale, type and description of an axis or a channel."""
    unit = spec.get("unit", "") or ""
    if not isinstance(unit, str):
        raise InputError(f"{where}: its unit is not text but a JSON {json_kind(unit)}",
                         file=name)
    scale = spec_scale(spec)
    if isinstance(scale, bool) or not isinstance(scale, (int, float)):
        raise InputError(f"{where}: its scale is not a number", file=name)
    if not np.isfinite(scale) or scale == 0:
        raise InputError(f"{where}: its scale is {scale}", file=name)
    if not isinstance(kind, str):
        raise InputError(f"{where}: its type is not text", file=name)
    return dict(unit=unit, scale=float(scale), type=kind, description=str(description))


def find_ndscan_roots(names) -> list[str]:
    """The ndscan root prefixes among dataset ``names`` (as ndscan.results.tools does)."""
    roots = [n[: -len(_SCHEMA_KEY)] for n in names
             if n == _SCHEMA_KEY or n.endswith("." + _SCHEMA_KEY)]
    if not roots and "ndscan.axes" in names:
        roots = ["ndscan."]
    return sorted(roots)


def read_scan(datasets, root: str, name: str, contents: ResultsFileContents) -> NdscanScan:
    """The scan at ``root``: its schema and axes read now, each channel when first used."""
    def get(key, check):
        return check(one_value(datasets[root + key][0], root + key, name)) \
            if root + key in datasets else None

    with contents:
        axes = tuple(_axis(datasets, root, i, ax, name)
                     for i, ax in enumerate(_json(datasets, root + "axes", name, list)))
        channels, subscans, declared = {}, {}, {}
        for cname, spec in _json(datasets, root + "channels", name, dict).items():
            where = f"root '{root}', dataset '{root}channels': channel '{cname}'"
            spec = _entry(spec, where, name)
            key = root + ("points.channel_" if axes else "point.") + cname
            if spec.get("type") == "subscan":    # "<scan>_spec": each point's subscan schema
                subscans[cname[:-len("_spec")] if cname.endswith("_spec") else cname] = key
            elif key in datasets:       # else not saved (ndscan's save_by_default=False)
                channels[cname] = (key, _fields(spec, spec.get("type", "float"),
                                                spec.get("description", ""), where, name))
                shape = contents.declared_shape(key)      # None: refused if read
                declared[cname] = None if shape is None else (key, shape[0] if shape else 1)
        completed = get("completed", lambda v: _flag(v, root + "completed", name))
        rev = get(_SCHEMA_KEY, lambda v: _integer(v, root + _SCHEMA_KEY, name))
        source_id = get("source_id", lambda v: _text(v, root + "source_id", name))
        fqn = get("fragment_fqn", lambda v: _text(v, root + "fragment_fqn", name))
    return NdscanScan(
        root=root, source_id=source_id, fragment_fqn=fqn, completed=completed,
        schema_revision=rev, axes=axes,
        channels=LazyMapping(channels, lambda c: _quantity(
            datasets, root, channels[c][0], c, name, **channels[c][1])),
        subscans=LazyMapping(subscans, lambda s: _subscan_schema(
            datasets[subscans[s]][0] if subscans[s] in datasets else None)),
        declared_points=declared)


def _axis(datasets, root: str, i: int, ax, name: str) -> Quantity:
    where = f"root '{root}', dataset '{root}axes': axis {i}"
    param = _entry(_entry(ax, where, name), where, name, "param")
    spec = _entry(param, where + " 'param'", name, "spec")
    fqn = param.get("fqn", f"axis_{i}")
    if not isinstance(fqn, str):
        raise InputError(f"{where}: its fqn is not text", file=name)
    return _quantity(datasets, root, f"{root}points.axis_{i}", fqn.split(".")[-1], name,
                     fqn=fqn,
                     **_fields(spec, param.get("type", "float"),
                               param.get("description", ""), where, name))


def _flag(v, key: str, name: str) -> bool:
    if isinstance(v, bool) or (isinstance(v, int) and v in (0, 1)):
        return bool(v)
    raise InputError(f"dataset '{key}' is not true or false: {short_repr(v)}", file=name)


def _integer(v, key: str, name: str) -> int:
    if isinstance(v, int) and not isinstance(v, bool):
        return v
    raise InputError(f"dataset '{key}' is not an integer: {short_repr(v)}", file=name)


def _text(v, key: str, name: str) -> str:
    if isinstance(v, str):
        return v
    raise InputError(f"dataset '{key}' is not text: {short_repr(v)}", file=name)


def _subscan_schema(values) -> dict:
    # the schema ndscan pushes with every point (JSON text); the first one that parses
    for text in np.atleast_1d(values if values is not None else []):
        try:
            spec = json.loads(text)
        except (TypeError, ValueError, RecursionError):
            continue
        if isinstance(spec, dict):
            return spec
    return {}


def _quantity(datasets, root: str, key: str, short: str, name: str, **kw) -> Quantity:
    if key not in datasets:
        raise InputError(f"root '{root}': dataset '{key}' missing", file=name)
    v = np.atleast_1d(np.asarray(datasets[key][0]))
    return Quantity(name=short, dataset=key, values=v, **kw)
