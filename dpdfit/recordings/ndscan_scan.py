"""One ndscan scan as read: its axes and result channels, point by point, and its subscans.

ndscan (``ndscan/experiment/entry_point.py``) stores every value in SI base units; a
quantity's ``scale`` is the factor of the ``unit`` it is shown in (a time shown in
``us`` has scale 1e-6 and is stored in seconds), so the shown value is ``stored /
scale`` (:attr:`Quantity.shown`, :meth:`NdscanScan.points` with ``shown=True``).
:mod:`.ndscan_roots` reads a scan from its root in a results file.

Subscans.  ndscan's ``setattr_subscan`` (``ndscan/experiment/subscan.py``) records a
subscan named ``<s>`` in its parent's result channels: ``<s>_axis_<i>`` (the
inner coordinates, one array per outer point), ``<s>_channel_<name>`` (each
inner result channel, one array per outer point) and ``<s>_spec`` (type
``subscan``: the inner scan's schema as JSON, with each axis's parameter spec
and each channel's ``unit`` and ``scale``).  :func:`flatten_subscan` turns that
into an ordinary :class:`NdscanScan` with one point per inner point:
the inner axes and channels first (named as the inner scan names them), then
the outer scan's axes and channels, each outer value repeated for its inner
points.  A name the inner scan and the outer one share is the inner one.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from dpdfit.errors import InputError

from .units import scale_from_metadata

__all__ = ["Quantity", "NdscanScan", "spec_scale", "flatten_subscan"]


@dataclass(frozen=True)
class Quantity:
    """One ndscan axis or result channel: its values as stored and how they are shown."""

    name: str
    dataset: str
    values: np.ndarray
    unit: str = ""
    scale: float = 1.0
    type: str = "float"
    fqn: str | None = None
    description: str = ""

    @property
    def shown(self) -> np.ndarray:
        """The values in ``unit`` (stored / scale), as ndscan's applet shows them."""
        return self.values / self.scale if self.values.dtype.kind in "fiu" else self.values


@dataclass(frozen=True)
class NdscanScan:
    """One ndscan root: the scan's axes and result channels, point by point.

    Read from a file, ``channels`` and ``subscans`` are read-only mappings whose
    values are read on first access (:class:`~.lazy_mapping.LazyMapping`), and
    ``declared_points`` gives each channel's ``(dataset, number of points)`` from the
    shape its dataset declares."""

    root: str
    source_id: str | None
    fragment_fqn: str | None
    completed: bool | None
    schema_revision: int | None
    axes: tuple = ()
    channels: Mapping = field(default_factory=dict)
    subscans: Mapping = field(default_factory=dict)
    declared_points: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def n_points(self) -> int:
        """Number of scan points (length of the first axis, else of a channel; 0 if none)."""
        q = self.axes[0] if self.axes else next(iter(self.channels.values()), None)
        return 0 if q is None else len(q.values)

    def point_counts(self) -> dict:
        """``{dataset: number of points}`` of every axis and channel; a channel's from
        ``declared_points`` when it names the channel (which is then not read: None
        there leaves out a channel whose dataset is refused if it is used)."""
        counts = {q.dataset: len(q.values) for q in self.axes}
        for c in self.channels:
            if c not in self.declared_points:
                q = self.channels[c]
                counts[q.dataset] = len(q.values)
            elif self.declared_points[c] is not None:
                counts.update([self.declared_points[c]])
        return counts

    def axis(self, name: str) -> Quantity:
        """An axis by its short name (last part of the parameter's fqn) or its fqn."""
        for a in self.axes:
            if name in (a.name, a.fqn):
                return a
        raise KeyError(name)

    def subscan(self, name: str, file: str | None = None) -> NdscanScan:
        """Subscan ``name`` as a scan of its own: one point per inner point, the outer
        point's axes and channels repeated (:func:`flatten_subscan`)."""
        return flatten_subscan(self, name, file)

    def channel(self, name: str) -> Quantity:
        """A result channel by its name (KeyError if the scan has none of that name)."""
        return self.channels[name]

    def points(self, shown: bool = False) -> pd.DataFrame:
        """One row per point: the axes, then the channels (a per-shot channel holds one
        array per row).  Stored values, or with ``shown`` the values in each quantity's
        unit; ``attrs["units"]`` gives ``{column: (unit, scale)}``."""
        cols, units = {}, {}
        for q in (*self.axes, *self.channels.values()):
            v = q.shown if shown else q.values
            cols[q.name] = list(v) if v.ndim > 1 else v
            units[q.name] = (q.unit, q.scale)
        df = pd.DataFrame(cols)
        df.attrs["units"] = units
        df.attrs["root"] = self.root
        return df


def spec_scale(spec: dict):
    """The ``scale`` of an ndscan axis or channel spec.  ndscan always writes it,
    defaulting it from the unit as ARTIQ does (``ndscan/experiment/parameters.py``,
    ``result_channels.py``); a spec without one gets it the same way."""
    if spec.get("scale") is None:
        return scale_from_metadata({"unit": spec.get("unit") or ""})
    return spec["scale"]


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
