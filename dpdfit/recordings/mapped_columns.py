"""One column of a campaign table from one results file, as a mapping describes it.

:func:`column_values` takes a column's :class:`~.mapping.ColumnSpec` and a
:class:`~.artiq.ResultsFile` (and the ndscan scan the source reads) and
returns the column's values, one per row, in the column's documented unit:
the value found (axis, channel, argument, parameter, dataset, provenance or
constant), then per-shot counting, labels, formatting, and the unit
conversion with its checks (finite numbers, integers where the column counts).
Every refusal is an InputError naming the file, the root and dataset, and the
mapping key with its line.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from dpdfit.errors import InputError

from .artiq import ResultsFile
from .mapping import ColumnSpec
from .mapping_lines import one_line
from .units import COLUMN_KINDS, UnitError, convert, scale_from_metadata, stored_unit

__all__ = ["column_values", "fail"]

_INTEGER = tuple(c for c, (k, _) in COLUMN_KINDS.items() if k == "number")


def fail(spec: ColumnSpec, rf: ResultsFile, msg: str, scan=None, dataset=None):
    """Raise the InputError of a refused column value: ``msg`` prefixed with the ndscan
    root and dataset when given, the mapping key and line appended, naming ``rf``'s
    file.

    Parameters
    ----------
    spec : ColumnSpec
        The column being read.
    rf : ResultsFile
        The results file being read.
    msg : str
        What is wrong with the value.
    scan : NdscanScan, optional
        The scan the source reads (its root is named).
    dataset : str, optional
        The HDF5 dataset the value came from.

    Raises
    ------
    InputError
        Always.
    """
    where = []
    if scan is not None:
        where.append(f"root '{scan.root}'")
    if dataset:
        where.append(f"dataset '{dataset}'")
    prefix = ", ".join(where) + ": " if where else ""
    raise InputError(one_line(f"{prefix}{msg} ({spec.where()})"), file=rf.run.file)


def column_values(spec: ColumnSpec, rf: ResultsFile, scan, n: int) -> np.ndarray:
    """One column's ``n`` values from one results file, in the column's unit."""
    if spec.source == "expr":
        v, file_unit, dataset, tol = _computed(spec, rf, scan, n)
    else:
        (v, file_unit, dataset), tol = _found(spec, rf, scan, n), 0.0
    if spec.count is not None:
        v = _count(v, spec, rf, scan, dataset)
    if spec.labels is not None:
        v = _labelled(v, spec, rf, scan, dataset)
    if spec.format is not None:
        v = _formatted(v, spec, rf, scan, dataset)
    return _in_unit(v, spec, spec.unit or file_unit, rf, scan, dataset, tol)


def _found(spec: ColumnSpec, rf: ResultsFile, scan, n: int):
    """(values, the unit they are stored in or None, the HDF5 dataset) of a plain source."""
    src, name = spec.source, spec.name
    file_unit, dataset = None, None
    if src == "value":                         # a constant is in the column's own unit
        v = np.full(n, name, dtype=object if isinstance(name, str) else None)
        file_unit = COLUMN_KINDS[spec.column][1]
    elif src in ("axis", "channel"):
        try:
            q = scan.axis(name) if src == "axis" else scan.channel(name)
        except KeyError:
            known = [a.name for a in scan.axes] if src == "axis" else list(scan.channels)
            fail(spec, rf, f"no {src} '{name}' (the scan has: {', '.join(known) or 'none'})",
                  scan)
        dataset, v = q.dataset, q.values[:n]
        file_unit = stored_unit(q.unit, q.scale)
        if file_unit is None and spec.unit is None:
            fail(spec, rf, f"shown in '{q.unit}' with scale {q.scale:g}: the stored unit is "
                  "not clear; say it with 'unit'", scan, dataset)
    elif src in ("argument", "parameter"):
        pool = rf.run.arguments if src == "argument" else rf.run.ndscan_overrides
        if name not in pool:
            fail(spec, rf, f"the run has no {src} '{name}' (it has: "
                  f"{', '.join(map(str, pool)) or 'none'})")
        value = _scannable(pool[name], spec, rf)
        v = np.full(n, value, dtype=object if isinstance(value, str) else None)
    elif src == "dataset":
        if name not in rf.datasets:
            fail(spec, rf, f"no dataset '{name}'")
        raw, attrs = rf.datasets[name]
        dataset, v = name, np.asarray(raw)
        v = np.full(n, v[()]) if v.ndim == 0 else v
        if "unit" in attrs:
            # ARTIQ's rule: no 'scale' means the unit's SI factor (kHz: stored in Hz)
            file_unit = stored_unit(str(attrs.get("unit")), scale_from_metadata(attrs))
    else:                                                  # provenance
        value = {"rid": rf.run.rid, "file": rf.run.file,
                 "start_time": None if rf.run.start_time is None
                 else rf.run.start_time.isoformat()}[name]
        if value is None:
            fail(spec, rf, f"the results file has no '{name}'")
        v = np.full(n, value, dtype=object if isinstance(value, str) else None)
    if np.asarray(v).dtype.kind == "c":        # numpy would keep the real part, warning
        fail(spec, rf, f"values are complex numbers ({np.asarray(v).dtype}), which no "
              "campaign column takes: record the parts you mean as real datasets", scan,
              dataset)
    return v, file_unit, dataset


def _scannable(value, spec: ColumnSpec, rf: ResultsFile):
    """An argument's value; a Scannable argument (ARTIQ's ``{"ty": "NoScan", "value":
    ...}``) held fixed gives its value, one that was scanned is refused."""
    if isinstance(value, dict) and "ty" in value:
        if value["ty"] == "NoScan" and "value" in value:
            return value["value"]
        fail(spec, rf, f"argument '{spec.name}' is a {value['ty']} (scanned): its values "
              "are in the run's datasets; map the dataset instead")
    return value


def _computed(spec: ColumnSpec, rf: ResultsFile, scan, n: int):
    """(values, unit, None, integer tolerance) of an ``expr`` column: every source
    read as stored, the result in the one unit they share (or ``unit``)."""
    units, narrow = set(), [False]

    def lookup(source, name, column=None):
        v, unit, dataset = _found(replace(spec, source=source, name=name), rf, scan, n)
        try:
            x = np.asarray(v, dtype=float) if np.asarray(v).dtype.kind != "f" else v
        except (TypeError, ValueError):
            x = None
        if x is None or _text(v) is not None:
            fail(spec, rf, f"{source}('{name}') is not a number (e.g. {v[0]!r})", scan, dataset)
        if column is not None:
            if x.ndim != 2 or not -x.shape[1] <= column < x.shape[1]:
                fail(spec, rf, f"{source}('{name}')[:, {column}]: the values have shape "
                      f"{x.shape}, no column {column}", scan, dataset)
            x = x[:, column]
        if x.ndim != 1 or len(x) != n:
            fail(spec, rf, f"{source}('{name}') has shape {x.shape}, not one value per row "
                  f"({n})", scan, dataset)
        narrow[0] |= x.dtype.itemsize < 8
        if unit:
            units.add(unit)
        return x

    v = spec.expression.evaluate(lookup)
    if len(units) > 1 and spec.unit is None:
        fail(spec, rf, f"the expression mixes the units {', '.join(sorted(units))}: say the "
              "unit of its result with 'unit'", scan)
    # a count computed from stored probabilities is an integer only up to their rounding
    tol = 1e-6 if narrow[0] else 1e-9
    return np.broadcast_to(v, (n,)).copy(), (units.pop() if units else ""), None, tol


def _count(v, spec, rf, scan, dataset) -> np.ndarray:
    rows = list(v) if v.dtype == object or v.ndim == 2 else None
    if rows is None:
        fail(spec, rf, "'count' needs per-shot outcomes (one array per point)", scan, dataset)
    if spec.count == "all":                  # NaN marks a shot never taken (pre-filled)
        return np.array([int(np.count_nonzero(~_missing(np.asarray(r).ravel())))
                         for r in rows], dtype=np.int64)
    want = np.atleast_1d(spec.count)
    return np.array([int(np.isin(np.asarray(r).ravel(), want).sum()) for r in rows],
                    dtype=np.int64)


def _missing(r: np.ndarray) -> np.ndarray:
    return np.isnan(r) if r.dtype.kind == "f" else np.zeros(r.shape, dtype=bool)


def _labelled(v, spec, rf, scan, dataset) -> np.ndarray:
    labels = {str(k): str(x) for k, x in spec.labels.items()}
    out = []
    for i, x in enumerate(v):
        k = str(int(x)) if isinstance(x, (int, float, np.number)) and float(x).is_integer() \
            else str(x)
        if k not in labels:
            fail(spec, rf, f"point {i + 1}: code {k} has no label (labels: "
                  f"{', '.join(labels)})", scan, dataset)
        out.append(labels[k])
    return np.array(out, dtype=object)


def _formatted(v, spec, rf, scan, dataset) -> np.ndarray:
    out = []
    for x in v:
        if isinstance(x, (float, np.floating)) and float(x).is_integer():
            x = int(x)
        elif isinstance(x, np.integer):
            x = int(x)
        try:
            out.append(spec.format.format(x))
        except (ValueError, TypeError) as exc:           # e.g. {:d} of 0.5 or of text
            fail(spec, rf, f"format '{spec.format}' does not apply to {x!r} ({exc})", scan,
                  dataset)
    return np.array(out, dtype=object)


def _text(v):
    """The first text (str or bytes) among the values, or None: numpy would read
    ``"1.5"`` as a number, and a number column takes no text."""
    v = np.asarray(v)
    if v.dtype.kind in "SU":
        return v.flat[0] if v.size else None
    if v.dtype == object:
        return next((x for x in v.flat if isinstance(x, (str, bytes))), None)
    return None


def _why_arrays(spec: ColumnSpec, scan) -> str:
    for sub in (scan.subscans if scan is not None else ()):
        if str(spec.name).startswith(sub + "_"):
            return (f"it belongs to the ndscan subscan '{sub}': give the source "
                    f"subscan = \"{sub}\" and name the subscan's own axes and channels")
    return "per-shot outcomes need 'count'"


def _in_unit(v, spec: ColumnSpec, unit, rf, scan, dataset, tol: float = 0.0) -> np.ndarray:
    kind = COLUMN_KINDS[spec.column][0]
    if kind == "label":
        return np.asarray(v, dtype=object)
    try:
        x = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        fail(spec, rf, f"values are not numbers (e.g. {v[0]!r})", scan, dataset)
    if (t := _text(v)) is not None:
        fail(spec, rf, f"values are text, not numbers (e.g. {t!r})", scan, dataset)
    if x.ndim != 1:
        fail(spec, rf, f"one value per point expected, got an array of shape {x.shape} "
              f"({_why_arrays(spec, scan)})", scan, dataset)
    bad = ~np.isfinite(x)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        fail(spec, rf, f"point {i + 1} is {x[i]} (values must be finite)", scan, dataset)
    try:
        x = convert(x, unit or "", spec.column, full_scale_dbm=spec.full_scale_dbm)
    except UnitError as exc:
        hint = ""
        if spec.source in ("argument", "parameter") and not unit:
            hint = (f"; {spec.source}s carry no unit and ARTIQ/ndscan keep numbers in SI: "
                    "say the unit with 'unit'")
        fail(spec, rf, str(exc) + hint, scan, dataset)
    if spec.column in _INTEGER:
        r = np.round(x)
        bad = np.abs(r - x) > tol * np.maximum(1.0, np.abs(x))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            why = " (not within rounding of an integer: write round(...) if the values " \
                "were recorded rounded)" if spec.source == "expr" else ""
            fail(spec, rf, f"point {i + 1}: {spec.column} = {x[i]:.10g} must be an "
                  f"integer{why}", scan, dataset)
        return r.astype(np.int64)
    return x
