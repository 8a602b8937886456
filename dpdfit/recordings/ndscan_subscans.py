"""ndscan subscans: a scan inside every point of an outer scan, read as rows.

ndscan's ``setattr_subscan`` (``ndscan/experiment/subscan.py``) records a
subscan named ``<s>`` in its parent's result channels: ``<s>_axis_<i>`` (the
inner coordinates, one array per outer point), ``<s>_channel_<name>`` (each
inner result channel, one array per outer point) and ``<s>_spec`` (type
``subscan``: the inner scan's schema as JSON, with each axis's parameter spec
and each channel's ``unit`` and ``scale``).  :func:`flatten_subscan` turns that
into an ordinary :class:`~.artiq.NdscanScan` with one point per inner point:
the inner axes and channels first (named as the inner scan names them), then
the outer scan's axes and channels, each outer value repeated for its inner
points.  A name the inner scan and the outer one share is the inner one.
"""

from __future__ import annotations

import numpy as np

from dpdfit.errors import InputError

from .artiq import NdscanScan, Quantity, spec_scale

__all__ = ["flatten_subscan"]


def flatten_subscan(scan: NdscanScan, name: str, file: str | None = None) -> NdscanScan:
    """The subscan ``name`` of ``scan`` with one point per inner point (module doc);
    InputError naming ``file`` and the root when there is no such subscan or its
    arrays do not line up."""
    if name not in scan.subscans:
        raise InputError(f"root '{scan.root}': no subscan '{name}' (subscans: "
                         f"{', '.join(scan.subscans) or 'none'})", file=file)
    schema, prefix = scan.subscans[name], name + "_"
    members = {k: q for k, q in scan.channels.items()
               if k.startswith(prefix + "axis_") or k.startswith(prefix + "channel_")}
    axes = sorted((k for k in members if k.startswith(prefix + "axis_")),
                  key=lambda k: int(k[len(prefix + "axis_"):] or 0))
    if not axes:
        raise InputError(f"root '{scan.root}': subscan '{name}' has no saved axis "
                         f"('{prefix}axis_0')", file=file)
    rows = {k: _per_point(q, scan) for k, q in members.items()}
    n_outer = min(len(r) for r in rows.values())
    if scan.axes:                     # an interrupted scan may end inside a point
        n_outer = min([n_outer] + [len(q.values) for q in scan.axes])
    counts = np.array([len(r) for r in rows[axes[0]][:n_outer]], dtype=int)
    for k, r in rows.items():
        got = np.array([len(x) for x in r[:n_outer]], dtype=int)
        if not np.array_equal(got, counts):
            i = int(np.flatnonzero(got != counts)[0])
            raise InputError(f"root '{scan.root}': subscan '{name}', outer point {i + 1}: "
                             f"'{members[k].dataset}' has {got[i]} inner points but "
                             f"'{members[axes[0]].dataset}' has {counts[i]}", file=file)
    flat = {k: _joined(r[:n_outer], members[k]) for k, r in rows.items()}
    inner_axes = [_inner_axis(flat[k], members[k], schema, i) for i, k in enumerate(axes)]
    inner = {k[len(prefix + "channel_"):]: _inner_channel(flat[k], members[k], schema,
                                                           k[len(prefix + "channel_"):])
             for k in members if k.startswith(prefix + "channel_")}
    outer_axes = [_repeated(q, counts) for q in scan.axes]
    outer = {k: _repeated(q, counts) for k, q in scan.channels.items() if k not in members}
    return NdscanScan(root=f"{scan.root}{name}/", source_id=scan.source_id,
                      fragment_fqn=schema.get("fragment_fqn", scan.fragment_fqn),
                      completed=scan.completed, schema_revision=scan.schema_revision,
                      axes=(*inner_axes, *outer_axes), channels={**outer, **inner})


def _per_point(q: Quantity, scan: NdscanScan) -> list:
    v = q.values
    if not scan.axes:                 # a run without axes stores its one point as is
        return [np.asarray(v)]
    return [np.atleast_1d(np.asarray(x)) for x in v]


def _joined(rows: list, q: Quantity) -> np.ndarray:
    return np.concatenate(rows) if rows else np.asarray(q.values)[:0]


def _inner_axis(values, q: Quantity, schema: dict, i: int) -> Quantity:
    axes = schema.get("axes") or []
    param = axes[i].get("param", {}) if i < len(axes) else {}
    spec = param.get("spec", {})
    fqn = param.get("fqn", f"axis_{i}")
    return Quantity(name=fqn.split(".")[-1], dataset=q.dataset, values=values,
                    unit=spec.get("unit", "") or "", scale=float(spec_scale(spec)),
                    type=param.get("type", "float"), fqn=fqn,
                    description=param.get("description", ""))


def _inner_channel(values, q: Quantity, schema: dict, short: str) -> Quantity:
    spec = (schema.get("channels") or {}).get(short, {})
    return Quantity(name=short, dataset=q.dataset, values=values,
                    unit=spec.get("unit", "") or "", scale=float(spec_scale(spec)),
                    type=spec.get("type", "float"), description=spec.get("description", ""))


def _repeated(q: Quantity, counts: np.ndarray) -> Quantity:
    v = np.asarray(q.values)[:len(counts)]
    return Quantity(name=q.name, dataset=q.dataset, values=np.repeat(v, counts, axis=0),
                    unit=q.unit, scale=q.scale, type=q.type, fqn=q.fqn,
                    description=q.description)
