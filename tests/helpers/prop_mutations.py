"""Shared pieces of the property-based bad-input tests.

Strategies that mutate a valid CSV or JSON file (a cell replaced by NaN, inf,
text, empty, huge, negative or out-of-range values; a column dropped; a row
duplicated, dropped or the rows shuffled; only the header or one row kept;
0 bytes, a BOM, CRLF line endings, a semicolon separator, comment and blank
lines, bytes that are not UTF-8, a truncated file), small valid inputs made
from the bundled data sets, and :func:`outcome`, which runs a reader and
classifies what happened: ``"ok"`` (a valid result), ``"clean"`` (one
:class:`~dpdfit.errors.DpdfitError` line naming the file) or ``"traceback"``.

Hypothesis profiles (chosen by the environment variable HYPOTHESIS_PROFILE):

* ``ci`` (default): 30 examples per test, derandomized (reproducible in CI);
* ``thorough``: 600 examples per test, random seeds;
  ``HYPOTHESIS_PROFILE=thorough python -m pytest tests/recordings/test_reader_properties.py
  tests/cli/test_command_properties.py``.

``benchmarks/property_counts.py`` runs the same tests (under pytest, in a child
process that writes :data:`TALLY` to ``PROPERTY_TALLY_JSON``) and prints, per
reader and command, how many inputs were tried and how each ended.
"""

from __future__ import annotations

import atexit
import functools
import json
import os
import tempfile
from collections import Counter, defaultdict
from pathlib import Path

from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

from dpdfit.errors import DpdfitError
from tests.helpers.paths import ROOT

AOM = ROOT / "datasets" / "synthetic_aom"
CAMP = ROOT / "datasets" / "synthetic_campaign"

_COMMON = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                    HealthCheck.data_too_large])
settings.register_profile("ci", max_examples=30, derandomize=True, **_COMMON)
settings.register_profile("thorough", max_examples=600, **_COMMON)
settings.register_profile("counts", max_examples=int(os.environ.get("PROPERTY_EXAMPLES", 150)),
                          **_COMMON)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

#: reader or command -> Counter of outcomes ("ok", "clean", "traceback")
TALLY: dict[str, Counter] = defaultdict(Counter)
#: the messages of the failures counted (PROPERTY_COUNT_ONLY=1)
FAILURES: list[str] = []
#: when true (benchmarks/property_counts.py), a traceback is counted, not raised
COUNT_ONLY = os.environ.get("PROPERTY_COUNT_ONLY") == "1"


def _write_tally(path: str) -> None:
    Path(path).write_text(json.dumps({"tally": {k: dict(v) for k, v in TALLY.items()},
                                      "failures": FAILURES}))


#: with PROPERTY_TALLY_JSON=<path> (benchmarks/property_counts.py), TALLY and FAILURES
#: are written there as JSON when the test process ends
if os.environ.get("PROPERTY_TALLY_JSON"):
    atexit.register(_write_tally, os.environ["PROPERTY_TALLY_JSON"])

# ----------------------------------------------------------------------------- values

#: cell texts that a reader must either accept (when valid) or refuse in one line
BAD_CELLS = ["nan", "NaN", "NA", "inf", "-inf", "Infinity", "abc", "", " ", "1e308",
             "-1e308", "1e400", "-1", "-0.5", "0", "2", "1.5", "1e-320", "0.5", "7",
             "10000000000000000000000", "0x10", "1_0", "true", "None", '"', "#", "1;2"]


def cell_values():
    """Cell texts: the list above, any float (incl. nan/inf) or integer, short text."""
    return st.one_of(
        st.sampled_from(BAD_CELLS),
        st.floats(allow_nan=True, allow_infinity=True).map(repr),
        st.integers(min_value=-10**25, max_value=10**25).map(str),
        st.text(alphabet="abcAB01.-+e ,;\"#\t", max_size=6),
    )


def number_texts():
    """Text of a numeric command-line option: floats incl. nan/inf/huge, ints, junk."""
    return st.one_of(
        st.sampled_from(["nan", "inf", "-inf", "-1", "0", "1e308", "-1e308", "1e-320",
                         "abc", "", "0.5", "1", "2", "1e400"]),
        st.floats(allow_nan=True, allow_infinity=True).map(repr),
        st.integers(min_value=-10**6, max_value=10**6).map(str),
    )


# ----------------------------------------------------------------------------- CSV mutations

_ROW_OPS = ["cell", "cell", "cell", "drop_col", "dup_row", "drop_row", "shuffle",
            "header_only", "one_row"]
_TEXT_OPS = ["empty", "bom", "crlf", "semicolon", "comment", "blank", "not_utf8", "truncate"]


@st.composite
def csv_mutations(draw, max_ops: int = 3):
    """A list of 1..max_ops edits ``(op, i, j, value)``; indices are taken modulo the shape."""
    n = draw(st.integers(min_value=1, max_value=max_ops))
    ops = []
    for _ in range(n):
        op = draw(st.sampled_from(_ROW_OPS + _TEXT_OPS))
        i, j = draw(st.integers(0, 10**6)), draw(st.integers(0, 10**6))
        value = draw(cell_values()) if op == "cell" else None
        ops.append((op, i, j, value))
    return ops


def _split(text: str):
    lines = text.splitlines()
    comments = [ln for ln in lines if ln.startswith("#")]
    body = [ln for ln in lines if ln.strip() and not ln.startswith("#")]
    return comments, body[0].split(","), [ln.split(",") for ln in body[1:]]


def mutate_csv(text: str, ops, seed: int = 0) -> bytes:
    """``text`` (a valid CSV) with the edits ``ops`` applied, as bytes."""
    import random
    comments, header, rows = _split(text)
    tail = []
    for op, i, j, value in ops:
        ncol = max(len(header), 1)
        if op == "cell" and rows:
            row = rows[i % len(rows)]
            if row:
                row[j % len(row)] = value
        elif op == "drop_col" and header:
            k = j % ncol
            header = header[:k] + header[k + 1:]
            rows = [r[:k] + r[k + 1:] for r in rows]
        elif op == "dup_row" and rows:
            rows.insert(j % (len(rows) + 1), list(rows[i % len(rows)]))
        elif op == "drop_row" and rows:
            del rows[i % len(rows)]
        elif op == "shuffle":
            random.Random(i).shuffle(rows)
        elif op == "header_only":
            rows = []
        elif op == "one_row" and rows:
            rows = [rows[i % len(rows)]]
        else:
            tail.append((op, i, j))
    lines = comments + [",".join(header)] + [",".join(r) for r in rows]
    out = "\n".join(lines) + "\n"
    for op, i, j in tail:
        out = _text_op(out, op, i, j)
    return out if isinstance(out, bytes) else out.encode()


def _text_op(out, op, i, j):
    data = out if isinstance(out, bytes) else out.encode()
    lines = data.split(b"\n")
    k = i % len(lines)
    if op == "empty":
        return b""
    if op == "bom":
        return b"\xef\xbb\xbf" + data
    if op == "crlf":
        return data.replace(b"\r\n", b"\n").replace(b"\n", b"\r\n")
    if op == "semicolon":
        return data.replace(b",", b";")
    if op == "comment":
        return b"\n".join(lines[:k] + [b"# an inserted comment, with a comma"] + lines[k:])
    if op == "blank":
        return b"\n".join(lines[:k] + [b"", b"   "] + lines[k:])
    if op == "not_utf8":
        pos = j % (len(data) + 1)
        return data[:pos] + b"\xff\xfe\x80" + data[pos:]
    if op == "truncate":
        return data[: j % (len(data) + 1)]
    return data


# ----------------------------------------------------------------------------- JSON mutations

_JSON_VALUES = [float("nan"), float("inf"), float("-inf"), None, "text", "", [], {}, [1, 2],
                -1, 0, 1e308, 10**400, True, 0.5, "1.5", [[float("nan")]]]


def json_values():
    return st.one_of(st.sampled_from(_JSON_VALUES),
                     st.floats(allow_nan=True, allow_infinity=True),
                     st.integers(min_value=-10**30, max_value=10**30))


@st.composite
def json_mutations(draw, max_ops: int = 3):
    n = draw(st.integers(min_value=1, max_value=max_ops))
    ops = []
    for _ in range(n):
        op = draw(st.sampled_from(["set", "set", "set", "del", "del", "not_object",
                                   "empty", "bom", "not_utf8", "truncate"]))
        value = draw(json_values()) if op in ("set", "not_object") else None
        ops.append((op, draw(st.integers(0, 10**6)), value))
    return ops


def _paths(obj, prefix=()):
    """Every key path into nested dicts and lists (lists: first 3 items)."""
    out = []
    items = (obj.items() if isinstance(obj, dict) else
             enumerate(obj[:3]) if isinstance(obj, list) else [])
    for k, v in items:
        out.append(prefix + (k,))
        out.extend(_paths(v, prefix + (k,)))
    return out


def mutate_json(obj, ops) -> bytes:
    """``obj`` (a JSON-able dict) with ``ops`` applied, serialised (NaN as the literal)."""
    import copy
    obj = copy.deepcopy(obj)
    tail = []
    for op, i, value in ops:
        paths = _paths(obj)
        if op in ("set", "del") and paths:
            path = paths[i % len(paths)]
            parent = functools.reduce(lambda o, k: o[k], path[:-1], obj)
            if op == "set":
                parent[path[-1]] = copy.deepcopy(value)
            elif isinstance(parent, dict):
                del parent[path[-1]]
            else:
                parent.pop(path[-1])
        elif op == "not_object":
            obj = copy.deepcopy(value)
        else:
            tail.append((op, i, i))
    data = json.dumps(obj, indent=1).encode()
    for op, i, j in tail:
        data = _text_op(data, op, i, j)
    return data


# ----------------------------------------------------------------------------- valid inputs


def head_rows(path, keep) -> str:
    """The CSV ``path`` with its comment and header lines and the data rows ``keep(i, cells)``."""
    lines = Path(path).read_text().splitlines()
    out, n = [], -1
    for ln in lines:
        if ln.startswith("#"):
            out.append(ln)
            continue
        n += 1
        if n == 0 or keep(n - 1, ln.split(",")):
            out.append(ln)
    return "\n".join(out) + "\n"


@functools.lru_cache(maxsize=None)
def base_texts() -> dict:
    """Small valid files made from the bundled data (text), built once per process."""
    every5 = lambda i, c: i % 5 == 0  # noqa: E731
    t = {
        "amplitude": head_rows(AOM / "calibration_amplitude.csv", lambda i, c: i < 200 and i % 8 == 0),
        "phase": head_rows(AOM / "calibration_phase.csv", lambda i, c: i < 200 and i % 8 == 0),
        "populations": head_rows(CAMP / "populations.csv", lambda i, c: c[0] == "0.5"),
        "parity": head_rows(CAMP / "parity.csv",
                            lambda i, c: c[0] == "0.5" and c[2] == "1" and int(i) % 2 == 0),
        "gate_rates": (CAMP / "gate_rates.csv").read_text(),
        "time_scans": head_rows(CAMP / "time_scans.csv", lambda i, c: i < 12),
        "spectra": head_rows(CAMP / "spectra.csv", lambda i, c: i < 24),
        "traces_csv": (CAMP / "traces.csv").read_text(),
        "trace": "sample\n" + "\n".join(f"{0.001 * k:.3f}" for k in range(-20, 20)) + "\n",
        "runs": head_rows(CAMP / "calibration_amplitude.csv",
                          lambda i, c: c[0] in ("R001", "R002", "R003") and every5(i, c)),
        "campaign": (CAMP / "campaign.json").read_text(),
    }
    t.update(_made_texts(t))
    return t


def _made_texts(t) -> dict:
    """calibration.json, sweep.csv and a gate table made by the CLI from the small files."""
    from dpdfit.cli.main import main
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        (d / "amp.csv").write_text(t["amplitude"])
        (d / "pop.csv").write_text(t["populations"])
        (d / "par.csv").write_text(t["parity"])
        (d / "rates.csv").write_text(t["gate_rates"])
        argvs = [["calibrate", "--amplitude", d / "amp.csv", "--order-scan", "none",
                  "-o", d / "cal.json"],
                 ["sweep", d / "cal.json", "--amplitudes", "0.2:1:5", "-o", d / "sweep.csv"],
                 ["fidelity", "--populations", d / "pop.csv", "--parity", d / "par.csv",
                  "--gate-rates", d / "rates.csv", "-o", d / "gate.csv"]]
        import contextlib
        import io
        for argv in argvs:
            with contextlib.redirect_stdout(io.StringIO()), \
                    contextlib.redirect_stderr(io.StringIO()):
                code = main([str(a) for a in argv])
            assert code == 0, argv
        return {"calibration": (d / "cal.json").read_text(),
                "sweep": (d / "sweep.csv").read_text(),
                "gate": (d / "gate.csv").read_text()}


# ----------------------------------------------------------------------------- the property


class Traceback(AssertionError):
    """A reader ended in something other than a valid result or one clean error."""


def outcome(name: str, path, call, check) -> str:
    """Run ``call()``; ``"ok"`` if ``check(result)`` passes, ``"clean"`` for a
    DpdfitError of one line naming ``path``; anything else raises :class:`Traceback`
    (or is only counted, with PROPERTY_COUNT_ONLY=1).  Counted in :data:`TALLY`."""
    try:
        result = call()
    except DpdfitError as exc:
        msg = str(exc)
        if "\n" in msg or str(path) not in msg:
            return _fail(name, f"not one line naming {path}: {msg!r}")
        TALLY[name]["clean"] += 1
        return "clean"
    except Exception as exc:  # noqa: BLE001 - that is the failure being looked for
        return _fail(name, f"{type(exc).__name__}: {exc}", exc)
    try:
        check(result)
    except Exception as exc:  # noqa: BLE001 - an assertion, or a result that breaks on use
        return _fail(name, f"invalid result presented as valid: {type(exc).__name__}: {exc}",
                     exc)
    TALLY[name]["ok"] += 1
    return "ok"


def _fail(name, message, cause=None):
    TALLY[name]["traceback"] += 1
    FAILURES.append(f"{name}: {message}")
    if COUNT_ONLY:
        return "traceback"
    raise Traceback(f"{name}: {message}") from cause
