"""Hypothesis strategies of ARTIQ results files: the small lab's two files, edited.

:func:`file_edits` draws edits of the files :func:`~tests.helpers.small_artiq_lab.
write_small_lab` writes, and :func:`apply_file_edits` makes them with h5py: a dataset
(an ndscan axis, channel or schema key, or the run's ``rid``, ``start_time``, ``expid``,
``artiq_version``) replaced by a value of another dtype (integer, unsigned, float16,
complex, boolean, bytes, variable-length text, compound, opaque, ragged) and shape
(0-d, empty, 2-D), by JSON or PYON text of the wrong shape or nesting, or by a group;
a dataset deleted or added under a random name; ``unit``/``scale`` attributes of the
wrong type; a soft, external or hard link; the whole file replaced by other bytes.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from hypothesis import strategies as st

FILES = ("cal", "par")                # the amplitude calibration, the parity scan
#: the keys of each file an edit may aim at (under datasets/ unless they start with /)
KEYS = {
    "cal": ["ndscan.rid_1.axes", "ndscan.rid_1.channels", "ndscan.rid_1.points.axis_0",
            "ndscan.rid_1.points.channel_pd_power", "ndscan.rid_1.completed",
            "ndscan.rid_1.ndscan_schema_revision", "ndscan.rid_1.source_id"],
    "par": ["ndscan.rid_2.axes", "ndscan.rid_2.channels", "ndscan.rid_2.points.axis_0",
            "ndscan.rid_2.points.channel_n_even", "ndscan.rid_2.points.channel_shots",
            "ndscan.rid_2.completed", "ndscan.rid_2.ndscan_schema_revision"],
}
TOP = ["/rid", "/start_time", "/run_time", "/expid", "/artiq_version", "/datasets"]

KINDS = ["f8", "f4", "f2", "i8", "i1", "u8", "?", "c16", "S", "str", "compound", "opaque",
         "ragged"]
SHAPES = [(), (0,), (1,), (3,), (8,), (11,), (2, 3), (0, 0), (8, 4), (11, 0)]
FILLS = [0, 1, -1, 0.5, 7, 2**62, float("nan"), float("inf"), 1e308, 5e-324]

JSON_TEXTS = ["5", '"x"', "[]", "{}", "null", "[1, 2]", '[{"param": 5}]',
              '[{"param": {"spec": []}}]', '[{"param": {"fqn": 5, "spec": {"scale": "x"}}}]',
              '[{"param": {"fqn": "a.amplitude", "spec": {"scale": 0}}}]',
              '[{"param": {"fqn": "a.amplitude", "spec": {"scale": 1e400, "unit": 5}}}]',
              '[{"param": {"fqn": "a.amplitude", "type": "int", "spec": null}}]',
              '{"pd_power": 5}', '{"pd_power": {"type": 5}}', '{"pd_power": []}',
              '{"pd_power": {"scale": null, "unit": 5}}', '{"pd_power": {"type": "subscan"}}',
              '{"n_even": {"scale": "1e3"}}', '{"shots": {"type": "opaque", "unit": []}}',
              "{", "[NaN]", '{"": {}}', "[" * 5000 + "]" * 5000, '{"a": ' * 3000 + "1" +
              "}" * 3000, "\ufeff[]", '"\\ud800"']
PYON_TEXTS = ["5", "[]", '"text"', "{", "{" * 3000, "None", "{'arguments': 5}",
              "{'arguments': []}", "{'arguments': {'amplitude': '0.5'}}",
              "{'arguments': {'amplitude': 1e400}}", "{'arguments': {'amplitude': [1, 2]}}",
              "{'arguments': {'amplitude': {'ty': 'NoScan', 'value': 'x'}}, 'dpd': 1}",
              "{'arguments': {'amplitude': {'ty': 'RangeScan', 'npoints': 1e400}}}",
              "{'arguments': {'amplitude': True, 'dpd': 'true'}}",
              "{'arguments': {'amplitude': 0.5, 'dpd': 'false'}}",
              "{'arguments': {'amplitude': 1j, 'dpd': 1}}",
              "{'arguments': {'amplitude': 0.5 + 0.5j, 'dpd': 1}}",
              "{'arguments': {'amplitude': 0.5, 'dpd': 10 ** 10 ** 10}}",
              "{'arguments': {'amplitude': 0.5, 'dpd': " + "9" * 5000 + "}}",
              "{'arguments': {'amplitude': 0.5, 'dpd': 1, 'ndscan_params': '{'}}",
              "{'arguments': {'amplitude': 0.5, 'dpd': 1, 'ndscan_params': {'overrides': 5}}}",
              "{'arguments': {'amplitude': nparray(5, 'f8', 'AAAA')}}",
              "{'class_name': 5, 'arguments': {'amplitude': 0.5, 'dpd': 1}}",
              "{'arguments': {'amplitude': 0.5, 'dpd': 1}, 'log_level': __import__('os')}"]
NAMES = ["x", "ndscan.rid_9.ndscan_schema_revision", "ndscan.axes", "a/b/c", "\u00e9",
         "n" * 300, " ", "ndscan.rid_1.points.channel_extra", "ndscan.rid_2.ndscan_schema_rev"]


def array_specs():
    """(kind, shape, fill) of a generated dataset value."""
    return st.tuples(st.sampled_from(KINDS), st.sampled_from(SHAPES), st.sampled_from(FILLS))


def make_array(kind: str, shape: tuple, fill):
    """A value of dtype ``kind`` and ``shape`` filled with ``fill`` (as far as it fits)."""
    import h5py
    n = int(np.prod(shape))
    if kind in ("f8", "f4", "f2", "c16"):
        with np.errstate(over="ignore"):
            return np.full(shape, fill, dtype=kind) + (1j if kind == "c16" else 0)
    if kind in ("i8", "i1", "u8", "?"):
        info = np.iinfo(kind) if kind != "?" else None
        v = fill if isinstance(fill, int) and (info is None or info.min <= fill <= info.max) \
            else 1
        return np.full(shape, v, dtype=kind)
    if kind == "S":
        return np.full(shape, b"\xff\xfeab", dtype="S4")
    if kind == "str":
        return np.array(["{" + str(fill)] * n, dtype=h5py.string_dtype()).reshape(shape)
    if kind == "compound":
        return np.zeros(shape, dtype=[("a", "f8"), ("b", "i4")])
    if kind == "opaque":
        return np.zeros(shape, dtype="V3")
    # ragged: ``fill`` 0 gives every element empty (a per-shot channel with no shot),
    # else lengths 0, 1, 2, 0, ...
    ragged = np.empty(n, dtype=h5py.vlen_dtype(np.float64))
    for i in range(n):
        ragged[i] = np.arange(0 if fill == 0 else i % 3, dtype=float)
    return ragged.reshape(shape)


@st.composite
def file_edit(draw):
    """One edit: (file, action, key, detail)."""
    f = draw(st.sampled_from(FILES))
    key = draw(st.one_of(st.sampled_from(KEYS[f]), st.sampled_from(TOP)))
    action = draw(st.sampled_from(["array", "array", "text", "delete", "group", "add",
                                   "attrs", "link", "bytes"]))
    if action == "array":
        return (f, action, key, draw(array_specs()))
    if action == "text":
        texts = PYON_TEXTS if key == "/expid" else JSON_TEXTS
        return (f, action, key, draw(st.sampled_from(texts)))
    if action == "add":
        return (f, action, draw(st.sampled_from(NAMES)), draw(array_specs()))
    if action == "attrs":
        return (f, action, key, draw(st.sampled_from(
            [("unit", 5), ("scale", "x"), ("scale", np.array([1.0, 2.0])), ("unit", b"\xff"),
             ("scale", 0.0), ("unit", "us"), ("scale", 1e-300)])))
    if action == "link":
        return (f, action, key, draw(st.sampled_from(["soft", "dangling", "external",
                                                      "hard"])))
    if action == "bytes":
        return (f, action, key, draw(st.sampled_from(["empty", "junk", "signature",
                                                      "truncated"])))
    return (f, action, key, None)


def file_edits():
    return st.lists(file_edit(), min_size=1, max_size=3)


def apply_file_edits(paths: dict, outside: Path, edits) -> None:
    """Make ``edits`` on the files ``paths`` ({"cal": path, "par": path}); ``outside``
    is a results file outside the lab's folder, the target of external links."""
    import h5py
    for f, action, key, detail in edits:
        path = paths[f]
        if action == "bytes":
            raw = path.read_bytes()
            path.write_bytes({"empty": b"", "junk": b"\x00\x01junk" * 50,
                              "signature": b"\x89HDF\r\n\x1a\n" + b"\x00" * 100,
                              "truncated": raw[:len(raw) // 2]}[detail])
            continue
        try:
            with h5py.File(path, "r+") as h5:
                _edit(h5, action, _where(key), detail, outside)
        except OSError:
            continue                        # not HDF5 any more (an earlier edit)
        except (KeyError, ValueError, TypeError):
            continue                        # its place is gone (an earlier edit): not made


def _where(key: str) -> str:
    return key if key.startswith("/") else "/datasets/" + key


def _edit(h5, action: str, where: str, detail, outside: Path) -> None:
    import h5py
    if action == "add":
        if where not in h5:
            h5.require_group("/datasets") if "/datasets" not in h5 else None
            if isinstance(h5.get("/datasets"), h5py.Group):
                h5[where] = make_array(*detail)
        return
    if where in h5 or h5.get(where, getlink=True) is not None:
        del h5[where]
    if action == "array":
        h5[where] = make_array(*detail)
    elif action == "text":
        h5[where] = detail
    elif action == "group":
        h5.create_group(where).create_dataset("x", data=1)
    elif action == "attrs":
        h5[where] = np.arange(8.0)
        h5[where].attrs[detail[0]] = detail[1]
    elif action == "link":
        if detail == "soft":
            h5[where] = h5py.SoftLink("/rid")
        elif detail == "dangling":
            h5[where] = h5py.SoftLink("/nowhere")
        elif detail == "external":
            h5[where] = h5py.ExternalLink(str(outside), "/datasets/secret")
        elif where != "/artiq_version" and "/artiq_version" in h5:
            h5[where] = h5["/artiq_version"]
    # "delete": done above


def write_outside_file(path: Path) -> None:
    """A results file outside the lab, the target of the external links."""
    import h5py
    with h5py.File(path, "w") as h5:
        h5["/datasets/secret"] = json.dumps([{"param": {"fqn": "a.amplitude", "spec": {}}}])
