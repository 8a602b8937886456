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

:func:`read_results_file` checks the file's signature, lists its datasets and
reads the run's provenance, and returns a frozen :class:`ResultsFile` whose
datasets, scans and channels are read when first used, only from the file
itself and within a size limit (:mod:`.hdf5_contents`): an import reads what
its mapping names and the structure of the ndscan roots it uses.  Every
problem is an :class:`~dpdfit.errors.InputError` naming the file, the root and
the dataset.
"""

from __future__ import annotations

import fnmatch
import logging
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pandas as pd

from dpdfit.errors import DpdfitError, InputError

from .hdf5_contents import (ResultsFileContents, check_signature, file_sha256, one_value,
                            short_repr)
from .lazy_mapping import LazyMapping
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
        overrides = params.get("overrides") if isinstance(params, dict) else None
        out = {}
        for fqn, entries in (overrides.items() if isinstance(overrides, dict) else ()):
            for e in (entries if isinstance(entries, (list, tuple)) else ()):
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
    """An ARTIQ results file: the run, its ndscan scans (by root) and plain datasets.

    ``datasets`` maps each name under ``datasets/`` to ``(value, attributes)`` and
    ``scans`` each ndscan root to its :class:`NdscanScan`; read from a file, both
    read a value on first access, through ``contents``
    (:class:`~.hdf5_contents.ResultsFileContents`).  The file is opened for each
    read, or once for a ``with`` block: ``with read_results_file(path) as rf: ...``."""

    run: Run
    scans: Mapping = field(default_factory=dict)
    datasets: Mapping = field(default_factory=dict)
    contents: ResultsFileContents | None = field(default=None, repr=False, compare=False)

    def __enter__(self) -> ResultsFile:
        if self.contents is not None:
            self.contents.__enter__()
        return self

    def __exit__(self, *exc_info) -> None:
        if self.contents is not None:
            self.contents.__exit__(*exc_info)

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


def read_results_file(path, name: str | None = None, *,
                      max_dataset_bytes: int | None = None) -> ResultsFile:
    """Read an ARTIQ results file (module doc).  InputError if it is not one.

    ``name`` is how messages and :attr:`Run.file` name the file (default: ``path``;
    the import names it relative to its mapping).  ``max_dataset_bytes`` is the
    largest dataset read (default
    :data:`~dpdfit.core.defaults.MAX_DATASET_BYTES`)."""
    h5py_module()
    path = Path(path)
    name = str(path) if name is None else str(name)
    check_signature(path, name)                  # 8 bytes: nothing else is HDF5
    contents = ResultsFileContents(path, name, max_dataset_bytes)
    with contents:                               # lists it, then reads the run's keys
        run = _run(contents, name)
    # hashed once the file proved to be a results file; in blocks, never whole
    run = replace(run, sha256=file_sha256(path, name))
    datasets = LazyMapping(contents.names(), contents.read)
    from .ndscan_roots import read_scan      # it builds this module's NdscanScan
    scans = LazyMapping(find_ndscan_roots(contents.names()),
                        lambda root: read_scan(datasets, root, name, contents))
    return ResultsFile(run, scans, datasets, contents)


def _run(contents: ResultsFileContents, name: str) -> Run:
    def top(key):
        v = contents.read_top(key)
        return None if v is None else one_value(v, key, name)

    with contents:
        text, rid, version = top("expid"), top("rid"), top("artiq_version")
        start, end = top("start_time"), top("run_time")
    expid = {}
    if text is not None:
        if not isinstance(text, str):
            raise InputError(f"dataset 'expid' is not PYON text but {short_repr(text)}",
                             file=name)
        try:
            expid = decode_pyon(text)
        except PyonError as exc:
            raise InputError(f"dataset 'expid': {exc}", file=name) from None
        if not isinstance(expid, dict):
            raise InputError("dataset 'expid' is not a dictionary", file=name)
        if not isinstance(expid.get("arguments") or {}, dict):
            raise InputError("dataset 'expid': its 'arguments' is not a dictionary", file=name)
        if not isinstance(expid.get("class_name", ""), (str, type(None))):
            raise InputError("dataset 'expid': its 'class_name' is not text", file=name)
    if rid is not None and (isinstance(rid, bool) or not isinstance(rid, (int, float))
                            or not float(rid).is_integer()):
        raise InputError(f"dataset 'rid' is not an integer: {short_repr(rid)}", file=name)
    if version is not None and not isinstance(version, str):
        raise InputError(f"dataset 'artiq_version' is not text: {short_repr(version)}",
                         file=name)
    return Run(file=name, sha256="", rid=None if rid is None else int(rid),
               start_time=_time(start, name, "start_time"),
               run_time=_time(end, name, "run_time"), expid=expid, artiq_version=version)


def _time(v, name: str, key: str):
    if v is None:
        return None
    try:
        if isinstance(v, bool):
            raise TypeError(key)
        return pd.Timestamp(float(v), unit="s", tz="UTC")
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"dataset '{key}' is not a time (seconds since the epoch): "
                         f"{short_repr(v)}", file=name) from None


def spec_scale(spec: dict):
    """The ``scale`` of an ndscan axis or channel spec.  ndscan always writes it,
    defaulting it from the unit as ARTIQ does (``ndscan/experiment/parameters.py``,
    ``result_channels.py``); a spec without one gets it the same way."""
    if spec.get("scale") is None:
        return scale_from_metadata({"unit": spec.get("unit") or ""})
    return spec["scale"]
