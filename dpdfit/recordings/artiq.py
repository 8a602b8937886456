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
point measured again appears again).  Values are stored in SI base units
(:mod:`.ndscan_scan`: :class:`~.ndscan_scan.NdscanScan`, each axis and channel a
:class:`~.ndscan_scan.Quantity`; :mod:`.ndscan_roots` reads them).

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

import pandas as pd

from dpdfit.errors import InputError

from .hdf5_contents import (ResultsFileContents, check_signature, file_sha256, h5py_module,
                            one_value, short_repr)
from .lazy_mapping import LazyMapping
from .ndscan_roots import find_ndscan_roots, read_scan
from .ndscan_scan import NdscanScan
from .pyon import PyonError, decode_pyon

__all__ = ["Run", "ResultsFile", "read_results_file"]

log = logging.getLogger(__name__)


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
class ResultsFile:
    """An ARTIQ results file: the run, its ndscan scans (by root) and plain datasets.

    ``datasets`` maps each name under ``datasets/`` to ``(value, attributes)`` and
    ``scans`` each ndscan root to its :class:`~.ndscan_scan.NdscanScan`; read from a file, both
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

