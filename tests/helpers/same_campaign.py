"""Two simulated campaign folders that agree up to the floating-point noise of the BLAS
kernel they were made with.

The simulator is deterministic for a given machine: the bundled campaign regenerates
bit for bit where it was made.  OpenBLAS picks its kernel by processor (Haswell, SkylakeX,
Zen, ...), and its sums round differently in the last bits; through the calibration fit
and the gate-time root-find that moves floats by ~1e-8 relative, and through the
heterodyne extraction of a 16-bit trace a tone power by < 0.001 dB (one count in
~1e-5 of the trace's samples).  That is what this comparison allows, far below any
recording's own noise (a tone power is repeatable to 0.015 dB at best); anything else
must be identical.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

#: relative tolerance of a float (the BLAS kernel's rounding through the fits)
RTOL = 1e-6
#: absolute tolerance of a power in dB (an ADC count flipped in the trace)
DB_ATOL = 1e-3
#: an integer trace may differ by one count in at most this fraction of its samples
COUNT_FRACTION = 1e-4


def _same_floats(a, b, atol, where):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape, f"{where}: shape {a.shape} != {b.shape}"
    ok = np.isclose(a, b, rtol=RTOL, atol=atol, equal_nan=True)
    assert ok.all(), f"{where}: {np.sum(~ok)} values differ beyond the kernel's noise"


def _same_json(a, b, where):
    if isinstance(a, dict):
        assert isinstance(b, dict) and set(a) == set(b), f"{where}: keys differ"
        for k in a:
            _same_json(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), f"{where}: lengths differ"
        for i, (x, y) in enumerate(zip(a, b)):
            _same_json(x, y, f"{where}[{i}]")
    elif isinstance(a, float) or isinstance(b, float):
        _same_floats(a, b, 0.0, where)
    else:
        assert a == b, f"{where}: {a!r} != {b!r}"


def _same_csv(a: Path, b: Path, where):
    x, y = pd.read_csv(a), pd.read_csv(b)
    assert list(x.columns) == list(y.columns) and len(x) == len(y), f"{where}: layout"
    for c in x.columns:
        if x[c].dtype.kind == "f" or y[c].dtype.kind == "f":
            atol = DB_ATOL if c.lower().endswith("_db") else 0.0
            _same_floats(x[c], y[c], atol, f"{where}, column {c}")
        else:
            assert x[c].equals(y[c]), f"{where}, column {c}: differs"


def _same_npz(a: Path, b: Path, where):
    x, y = np.load(a), np.load(b)
    assert sorted(x.files) == sorted(y.files), f"{where}: arrays differ"
    for k in x.files:
        u, v = x[k], y[k]
        assert u.shape == v.shape and u.dtype == v.dtype, f"{where}[{k}]: layout"
        if u.dtype.kind in "iu":
            d = np.abs(u.astype(np.int64) - v.astype(np.int64))
            assert d.max(initial=0) <= 1 and np.mean(d > 0) <= COUNT_FRACTION, \
                f"{where}[{k}]: {np.sum(d > 0)} samples differ, by up to {d.max()}"
        elif u.dtype.kind in "fc":
            # relative to the array's scale (a waveform crosses zero)
            scale = float(np.max(np.abs(v), initial=0.0))
            assert np.max(np.abs(u - v), initial=0.0) <= RTOL * scale, \
                f"{where}[{k}]: differs beyond the kernel's noise"
        else:
            assert np.array_equal(u, v), f"{where}[{k}]: differs"


def assert_same_campaign(new: Path, ref: Path, hashes_new: dict, hashes_ref: dict):
    """Every file of ``ref`` (by its hashes) is in ``new``, identical or, for data
    files, the same up to the BLAS kernel's noise (module doc)."""
    assert set(hashes_new) == set(hashes_ref), sorted(set(hashes_new) ^ set(hashes_ref))
    for name, h in hashes_ref.items():
        if hashes_new[name] == h:
            continue
        a, b = new / name, ref / name
        if name.endswith(".csv"):
            _same_csv(a, b, name)
        elif name.endswith(".npz"):
            _same_npz(a, b, name)
        elif name.endswith(".json"):
            _same_json(json.loads(a.read_text()), json.loads(b.read_text()), name)
        else:
            raise AssertionError(f"{name}: differs")
