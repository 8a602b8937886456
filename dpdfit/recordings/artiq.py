"""ARTIQ results files and the ndscan scans inside them.

An ARTIQ results file (``artiq/master/worker_impl.py``, ``worker_db.py``) is
HDF5 with a group ``datasets/`` (one HDF5 dataset per archived key; dotted keys
stay flat names; since ARTIQ 8 the attributes ``unit``, ``scale``,
``precision``), a group ``archive/``, and the run's ``rid``, ``start_time``,
``run_time`` (seconds since the epoch), ``expid`` (PYON text: ``file``,
``class_name``, ``arguments``, ...) and ``artiq_version``.

ndscan (``ndscan/experiment/entry_point.py``, ``ndscan/results/tools.py``)
writes each scan under a *root*, a prefix of dataset names (``ndscan.rid_<rid>.``;
older files ``ndscan.``) found by ``<prefix>ndscan_schema_revision`` (or, in files
older than that key, ``ndscan.axes``).  ``<prefix>axes`` and ``<prefix>channels``
are JSON (names, units, scales); ``<prefix>points.axis_<i>`` and
``<prefix>points.channel_<name>`` hold every point in acquisition order (a
point measured again appears again).  Values are stored in SI base units; a
quantity's ``scale`` is the factor of the ``unit`` it is shown in (a time shown
in ``us`` has scale 1e-6 and is stored in seconds), so the shown value is
``stored / scale`` (:meth:`NdscanScan.points` with ``shown=True``).

:func:`read_results_file` reads one file completely (these files are small:
one run's scans) and returns a frozen :class:`ResultsFile`.  Every problem is an
:class:`~dpdfit.errors.InputError` naming the file, the root and the dataset.
"""

from __future__ import annotations

import fnmatch
import hashlib
import io
import json
import logging
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from dpdfit.errors import DpdfitError, InputError

from .pyon import PyonError, decode_pyon
from .units import scale_from_metadata

__all__ = ["Run", "Quantity", "NdscanScan", "ResultsFile", "read_results_file",
           "find_ndscan_roots", "h5py_module", "spec_scale"]

log = logging.getLogger(__name__)

_SCHEMA_KEY = "ndscan_schema_revision"


def h5py_module():
    """h5py, or a DpdfitError that names the extra to install."""
    try:
        import h5py
    except ImportError:
        raise DpdfitError("reading ARTIQ results files needs h5py: pip install "
                          "'dpdfit[artiq]' (or pip install h5py)") from None
    return h5py


@dataclass(frozen=True)
class Run:
    """Provenance of one ARTIQ run: where its results file is and what the run was."""

    file: str
    sha256: str
    rid: int | None
    start_time: pd.Timestamp | None
    run_time: pd.Timestamp | None
    expid: dict = field(default_factory=dict)
    artiq_version: str | None = None

    @property
    def arguments(self) -> dict:
        """The experiment's arguments (``expid["arguments"]``)."""
        return dict(self.expid.get("arguments") or {})

    @property
    def ndscan_overrides(self) -> dict:
        """ndscan parameters fixed for the whole run: ``{fqn: value}`` (path ``*``)."""
        params = self.arguments.get("ndscan_params")
        if isinstance(params, (str, bytes)):
            try:
                params = decode_pyon(params)
            except PyonError:
                params = None
        out = {}
        for fqn, entries in ((params or {}).get("overrides") or {}).items():
            for e in entries or ():
                if isinstance(e, dict) and "value" in e:
                    out.setdefault(fqn, e["value"])
        return out


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
    """One ndscan root: the scan's axes and result channels, point by point."""

    root: str
    source_id: str | None
    fragment_fqn: str | None
    completed: bool | None
    schema_revision: int | None
    axes: tuple = ()
    channels: dict = field(default_factory=dict)
    subscans: dict = field(default_factory=dict)

    @property
    def n_points(self) -> int:
        """Number of scan points (length of the first axis, else of a channel; 0 if none)."""
        q = self.axes[0] if self.axes else next(iter(self.channels.values()), None)
        return 0 if q is None else len(q.values)

    def axis(self, name: str) -> Quantity:
        """An axis by its short name (last part of the parameter's fqn) or its fqn."""
        for a in self.axes:
            if name in (a.name, a.fqn):
                return a
        raise KeyError(name)

    def subscan(self, name: str, file: str | None = None) -> NdscanScan:
        """Subscan ``name`` as a scan of its own: one point per inner point, the outer
        point's axes and channels repeated (:func:`~.ndscan_subscans.flatten_subscan`)."""
        from .ndscan_subscans import flatten_subscan
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


@dataclass(frozen=True)
class ResultsFile:
    """An ARTIQ results file: the run, its ndscan scans (by root) and plain datasets."""

    run: Run
    scans: dict = field(default_factory=dict)
    datasets: dict = field(default_factory=dict)

    def scan(self, root: str | None = None) -> NdscanScan:
        """The scan at ``root`` (a glob such as ``ndscan.rid_*.`` is allowed); without
        ``root`` the file's only scan.  InputError when there is none or several."""
        roots = list(self.scans)
        if root is not None:
            roots = [r for r in roots if fnmatch.fnmatchcase(r, root)]
        if len(roots) == 1:
            return self.scans[roots[0]]
        if not self.scans:
            raise InputError("no ndscan root (no dataset '*ndscan_schema_revision' or "
                             "'ndscan.axes')", file=self.run.file)
        if not roots:
            raise InputError(f"no ndscan root matches '{root}' (roots: "
                             f"{', '.join(self.scans)})", file=self.run.file)
        raise InputError(f"{len(roots)} ndscan roots ({', '.join(roots)}): name one with "
                         "'root' in the mapping", file=self.run.file)


def find_ndscan_roots(names) -> list[str]:
    """The ndscan root prefixes among dataset ``names`` (as ndscan.results.tools does)."""
    roots = [n[: -len(_SCHEMA_KEY)] for n in names
             if n == _SCHEMA_KEY or n.endswith("." + _SCHEMA_KEY)]
    if not roots and "ndscan.axes" in names:
        roots = ["ndscan."]
    return sorted(roots)


def read_results_file(path, name: str | None = None) -> ResultsFile:
    """Read an ARTIQ results file (module doc).  InputError if it is not one.

    ``name`` is how messages and :attr:`Run.file` name the file (default: ``path``;
    the import names it relative to its mapping)."""
    h5py = h5py_module()
    path = Path(path)
    name = str(path) if name is None else str(name)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise InputError(f"cannot be read ({exc.strerror})", file=name) from None
    if not raw.startswith(b"\x89HDF\r\n\x1a\n"):
        raise InputError("not an HDF5 file (an ARTIQ results file is HDF5)", file=name)
    try:
        with h5py.File(io.BytesIO(raw), "r") as f:
            run = _run(f, name, hashlib.sha256(raw).hexdigest())
            datasets = {}
            if "datasets" in f:
                # a key with "/" is a nested group in the file (ARTIQ's h5py writes it so);
                # it is read under its key, "group/name"
                def take(k, d):
                    if isinstance(d, h5py.Dataset):
                        datasets[k] = (_plain(d[()]), dict(d.attrs))
                f["datasets"].visititems(take)
    except OSError as exc:
        raise InputError(f"not a readable HDF5 file ({exc})", file=name) from None
    scans = {r: _scan(datasets, r, name) for r in find_ndscan_roots(datasets)}
    return ResultsFile(run, scans, datasets)


def _plain(v):
    if isinstance(v, bytes):
        return v.decode("utf-8", errors="replace")
    if isinstance(v, np.ndarray) and v.dtype.kind == "O":
        return np.array([x.decode("utf-8", "replace") if isinstance(x, bytes) else x
                         for x in v.ravel()], dtype=object).reshape(v.shape)
    return v


def _run(f, name: str, sha: str) -> Run:
    def scalar(key):
        return _plain(f[key][()]) if key in f else None

    expid = {}
    text = scalar("expid")
    if text is not None:
        try:
            expid = decode_pyon(text)
        except PyonError as exc:
            raise InputError(f"dataset 'expid': {exc}", file=name) from None
        if not isinstance(expid, dict):
            raise InputError("dataset 'expid' is not a dictionary", file=name)
    rid = scalar("rid")
    return Run(file=name, sha256=sha, rid=None if rid is None else int(rid),
               start_time=_time(scalar("start_time"), name, "start_time"),
               run_time=_time(scalar("run_time"), name, "run_time"), expid=expid,
               artiq_version=scalar("artiq_version"))


def _time(v, name: str, key: str):
    if v is None:
        return None
    try:
        return pd.Timestamp(float(v), unit="s", tz="UTC")
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"dataset '{key}' is not a time (seconds since the epoch): {v!r}",
                         file=name) from None


def _json(datasets: dict, key: str, name: str):
    if key not in datasets:
        raise InputError(f"dataset '{key}' missing", file=name)
    try:
        return json.loads(datasets[key][0])
    except (TypeError, ValueError) as exc:
        raise InputError(f"dataset '{key}' is not JSON ({exc})", file=name) from None


def _scan(datasets: dict, root: str, name: str) -> NdscanScan:
    def get(key, default=None):
        return datasets[root + key][0] if root + key in datasets else default

    axes = []
    spec_axes = _json(datasets, root + "axes", name)
    for i, ax in enumerate(spec_axes):
        param = ax.get("param", {})
        spec = param.get("spec", {})
        fqn = param.get("fqn", f"axis_{i}")
        axes.append(_quantity(datasets, root, f"points.axis_{i}", fqn.split(".")[-1], name,
                              unit=spec.get("unit", ""), scale=spec_scale(spec),
                              type=param.get("type", "float"), fqn=fqn,
                              description=param.get("description", "")))
    channels, subscans = {}, {}
    for cname, spec in _json(datasets, root + "channels", name).items():
        key = ("points.channel_" if spec_axes else "point.") + cname
        if spec.get("type") == "subscan":     # "<scan>_spec": each point's subscan schema
            subscans[cname[:-len("_spec")] if cname.endswith("_spec") else cname] = \
                _subscan_schema(datasets.get(root + key, (None,))[0])
            continue
        if root + key not in datasets:
            continue               # not saved by default (ndscan's save_by_default=False)
        channels[cname] = _quantity(datasets, root, key, cname, name,
                                    unit=spec.get("unit", "") or "",
                                    scale=spec_scale(spec),
                                    type=spec.get("type", "float"),
                                    description=spec.get("description", ""))
    completed = get("completed")
    rev = get(_SCHEMA_KEY)
    return NdscanScan(root=root, source_id=get("source_id"), fragment_fqn=get("fragment_fqn"),
                      completed=None if completed is None else bool(completed),
                      schema_revision=None if rev is None else int(rev), axes=tuple(axes),
                      channels=channels, subscans=subscans)


def _subscan_schema(values) -> dict:
    # the schema ndscan pushes with every point (JSON text); the first one that parses
    for text in np.atleast_1d(values if values is not None else []):
        try:
            spec = json.loads(text)
        except (TypeError, ValueError):
            continue
        if isinstance(spec, dict):
            return spec
    return {}


def spec_scale(spec: dict):
    """The ``scale`` of an ndscan axis or channel spec.  ndscan always writes it,
    defaulting it from the unit as ARTIQ does (``ndscan/experiment/parameters.py``,
    ``result_channels.py``); a spec without one gets it the same way."""
    if spec.get("scale") is None:
        return scale_from_metadata({"unit": spec.get("unit") or ""})
    return spec["scale"]


def _quantity(datasets, root, key, short, name, **kw) -> Quantity:
    if root + key not in datasets:
        raise InputError(f"root '{root}': dataset '{root + key}' missing", file=name)
    v = np.atleast_1d(np.asarray(datasets[root + key][0]))
    try:
        scale = float(kw.pop("scale"))
    except (TypeError, ValueError):
        raise InputError(f"root '{root}': the scale of '{short}' is not a number",
                         file=name) from None
    if not np.isfinite(scale) or scale == 0:
        raise InputError(f"root '{root}': the scale of '{short}' is {scale}", file=name)
    return Quantity(name=short, dataset=root + key, values=v, scale=scale, **kw)
