"""Hypothesis strategies of import mappings: the small lab's mapping, edited adversarially.

:func:`mapping_texts` draws the TOML text of a mapping: the mapping of
:mod:`tests.helpers.small_artiq_lab` with a few edits (a value replaced at a key of
``[import]``, ``[campaign]``, a source or a column, by a value of the wrong type, a
huge number, a deeply nested table, a weird string, a boolean given as text, a long
expression or format; a key deleted or unknown; a further source), and now and then
an edit of the text itself.  The text is written by :func:`toml_text`, which also
writes what Python cannot print (an integer literal of any number of digits).
"""

from __future__ import annotations

import datetime as dt
import math
import re
import tomllib

from hypothesis import strategies as st

from tests.helpers.small_artiq_lab import SMALL_MAPPING

#: the small lab's mapping as a document
BASE = tomllib.loads(SMALL_MAPPING)
TABLES = ("calibration_amplitude", "parity")
COLUMN_KEYS = ("value", "axis", "channel", "argument", "parameter", "dataset", "run", "expr",
               "unit", "full_scale_dbm", "format", "labels", "count", "bogus")


class Raw(str):
    """TOML text written as it is (an integer of 5000 digits, a date, junk)."""


def toml_text(doc: dict) -> str:
    """TOML for ``doc``: top-level values first, then tables, arrays of tables, and a
    source's ``columns`` as its own ``[<table>.columns]`` section, as the guide writes."""
    lines = [f"{_key(k)} = {_value(v)}" for k, v in doc.items() if not _section(v)]
    for k, v in doc.items():
        if isinstance(v, dict):
            lines += ["", f"[{_key(k)}]"] + [f"{_key(a)} = {_value(b)}" for a, b in v.items()]
        elif _section(v):
            for entry in v:
                lines += ["", f"[[{_key(k)}]]"]
                lines += [f"{_key(a)} = {_value(b)}" for a, b in entry.items()
                          if not (a == "columns" and isinstance(b, dict))]
                if isinstance(entry.get("columns"), dict):
                    lines += [f"[{_key(k)}.columns]"] + [
                        f"{_key(a)} = {_value(b)}" for a, b in entry["columns"].items()]
    return "\n".join(lines) + "\n"


def _section(v) -> bool:
    return isinstance(v, dict) or (isinstance(v, list) and bool(v)
                                   and all(isinstance(e, dict) for e in v))


def _key(k: str) -> str:
    return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else _string(k)


def _string(s: str) -> str:
    out = []
    for c in s:
        if c in '"\\':
            out.append("\\" + c)
        elif ord(c) < 0x20 or ord(c) == 0x7F:
            out.append(f"\\u{ord(c):04x}")
        else:
            out.append(c)
    return '"' + "".join(out) + '"'


def _value(v) -> str:
    if isinstance(v, Raw):
        return str(v)
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) \
            else repr(v)
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, (dt.date, dt.datetime)):
        return v.isoformat()
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(a)} = {_value(b)}" for a, b in v.items()) + "}"
    raise TypeError(type(v))


# ----------------------------------------------------------------------------- values
WEIRD_STRINGS = ["", " ", "true", "false", "True", "1", "0", "-1", "1e400", "nan", "inf",
                 "None", "null", "{}", "[]", "{", "}", "R{:03d}", "{:1000000000d}",
                 "{:,.999999999f}", "{0.__class__}", "{!r}", "{0[0]}", "{:c}", "{}{}",
                 "%s", "\u00e9\u00e8\u4e2d", "\U0001F600", "a\tb", "line\nbreak",
                 "../../../etc/passwd", "/etc/passwd", "results/**/*.h5", "**", "*",
                 "[", "ndscan.rid_*.", "ndscan.", "amplitude", "pd_power", "phase",
                 "axis('amplitude')", "x" * 5000, "\\", "'", '"']
EXPRESSIONS = ["axis('amplitude') * 2", "channel('pd_power') ** 10 ** 100", "9 ** 9 ** 9",
               "(" * 300 + "1" + ")" * 300, "-" * 5000 + "1", "1 / 0", "1 // 0", "1 % 0",
               "round(channel('pd_power'), 10 ** 10)", "round(1e308 * 10)",
               "sum([" + ", ".join(["channel('pd_power')"] * 200) + "])",
               "dataset('x')[::0]", "channel('pd_power')[:, 5]", "channel('pd_power')[0]",
               "argument('amplitude') + 1", "argument('amplitude')[0]", "1" + "0" * 5000,
               "axis('amplitude') + channel('n_even')", "__import__('os')", "lambda: 1",
               "channel('pd_power') * 1e308 * 1e308", "1e400", "2 ** -2000", "abs(-1)",
               "sum(" * 100 + "[1]" + ")" * 100, "axis('{n}')", "channel('p_{sideband}')",
               "round(axis('amplitude'), -400)", "1j", "True + 1", "'text'"]
# the widths of a gigabyte last (shrinking tries the first entries first): should their
# bound (dpdfit.core.defaults.FORMAT_MAX_WIDTH) ever be lost, formatting one value with
# them would take minutes and gigabytes before failing
FORMATS = ["R{:03d}", "{0.__class__}", "{!r}", "{0[0]}", "{:c}", "{}{}", "{", "}", "{:x}",
           "{:%Y}", "{:e}", "R{0:{1}}", "{:>{width}}", "P{:09.3f}", "", "{:s}", "{:100000d}",
           "{:99999999999999999999d}", "{:" + "9" * 400 + "}", "{:1000000000d}",
           "{:.1000000000f}", "{:,.999999999f}", "{:0>300000000}"]
GLOBS = ["results/**/*.h5", "**", "*", "results/*/*/*.h5", "", " ", "/", "/etc/*",
         "../*", "../../**/*.h5", "results/[", "results/**/**/**/*.h5", "x" * 3000,
         "results/\u00e9/*.h5", "results/./*/../*/*/*.h5", "results//*/*/*.h5"]


def huge_ints():
    return st.one_of(st.integers(), st.integers(min_value=2**63 - 2, max_value=2**64 + 2),
                     st.integers(-2**64, -2**63 + 2),
                     st.integers(10, 5000).map(lambda n: Raw("1" + "0" * n)),
                     st.integers(10, 500).map(lambda n: Raw("-" + "9" * n)))


def scalars():
    return st.one_of(
        st.booleans(), huge_ints(),
        st.floats(allow_nan=True, allow_infinity=True),
        st.sampled_from([1e308, -1e308, 5e-324, 0.0, -0.0, 0.5, 2.0, 1.84e6]),
        st.sampled_from(WEIRD_STRINGS), st.text(max_size=30),
        st.sampled_from([Raw("1979-05-27T07:32:00Z"), Raw("1979-05-27"), Raw("07:32:00"),
                         Raw("0x7fffffffffffffff"), Raw("0o777"), Raw("1_000")]))


def nested(depth: int):
    """A table or array nested ``depth`` deep (TOML text, past any recursion limit)."""
    return st.sampled_from([Raw("{a = " * depth + "1" + "}" * depth),
                            Raw("[" * depth + "1" + "]" * depth)])


def values():
    """Any value a mapping key might be given."""
    leaf = scalars()
    tree = st.recursive(leaf, lambda kids: st.one_of(
        st.lists(kids, max_size=4),
        st.dictionaries(st.sampled_from(["a", "axis", "channel", "value", "0", "1", ""]),
                        kids, max_size=3)), max_leaves=8)
    return st.one_of(leaf, leaf, tree, st.integers(50, 3000).flatmap(nested))


def value_for(key: str):
    """A value for mapping key ``key``: one meant for it, or any."""
    meant = {"expr": st.sampled_from(EXPRESSIONS), "format": st.sampled_from(FORMATS),
             "files": st.one_of(st.sampled_from(GLOBS), st.lists(st.sampled_from(GLOBS),
                                                                 max_size=3)),
             "count": st.one_of(st.sampled_from(["all", "none", "1"]),
                                st.lists(st.one_of(huge_ints(), st.floats()), max_size=3)),
             "labels": st.dictionaries(st.sampled_from(["0", "1", "1e400", "-1", "x", ""]),
                                       scalars(), max_size=3),
             "unit": st.sampled_from(["", "us", "turn", "rad", "deg", "%", "dBm", "V",
                                      "kHz", "furlong", "1", "fraction"]),
             "run": st.sampled_from(["rid", "start_time", "file", "end", ""]),
             "value": st.one_of(scalars(), st.lists(scalars(), max_size=3))}
    if key in meant:
        return st.one_of(meant[key], meant[key], values())
    return values()


# ----------------------------------------------------------------------------- edits
def _paths():
    """Where an edit may land: (path within the document, the key it sets)."""
    paths = [(("import",), k) for k in ("complete_only", "skip_bad_files",
                                        "max_dataset_bytes", "bogus")]
    paths += [(("campaign",), k) for k in ("nu_hz", "name", "spectra_recorded",
                                           "predistortion_table", "bogus")]
    paths += [((), k) for k in ("import", "campaign", "parity", "spectra", "bogus")]
    for t in TABLES:
        paths += [((t, 0), k) for k in ("files", "root", "subscan", "columns", "bogus")]
        for c in BASE[t][0]["columns"]:
            paths += [((t, 0, "columns"), c)]
            paths += [((t, 0, "columns", c), k) for k in COLUMN_KEYS]
    return paths


PATHS = _paths()


NAMES = ["amplitude", "phase", "pd_power", "n_even", "shots", "dpd", "rid", "x", "",
         "ndscan.rid_1.points.axis_0", "lab.ParityScan.dpd", "P_{sideband}_{n}", "{n}"]


@st.composite
def column_specs(draw):
    """A column with one source and perhaps modifiers, each value meant for its key or
    adversarial: reaches the checks behind the mapping's (the files, the values)."""
    source = draw(st.sampled_from(["axis", "channel", "argument", "parameter", "dataset",
                                   "run", "value", "expr"]))
    spec = {source: draw(st.one_of(st.sampled_from(NAMES), value_for(source)))
            if source not in ("expr", "run", "value") else draw(value_for(source))}
    for modifier in draw(st.lists(st.sampled_from(["unit", "format", "labels", "count",
                                                   "full_scale_dbm"]), unique=True,
                                  max_size=2)):
        spec[modifier] = draw(value_for(modifier))
    return spec


@st.composite
def edits(draw):
    """("set", path, key, value) or ("del", path, key): half of them a column replaced
    by a whole column (:func:`column_specs`)."""
    if draw(st.booleans()):
        table = draw(st.sampled_from(TABLES))
        column = draw(st.sampled_from(list(BASE[table][0]["columns"]) + ["scan", "n01_10"]))
        return ("set", (table, 0, "columns"), column, draw(column_specs()))
    path, key = draw(st.sampled_from(PATHS))
    if draw(st.integers(0, 4)) == 0:
        return ("del", path, key)
    return ("set", path, key, draw(value_for(key)))


def edited(edit_list) -> dict:
    """The small lab's mapping with ``edit_list`` applied (a path that no longer
    leads to a table is skipped)."""
    doc = tomllib.loads(SMALL_MAPPING)
    for e in edit_list:
        node = doc
        for step in e[1]:
            try:
                node = node[step]
            except (KeyError, IndexError, TypeError):
                node = None
                break
        if isinstance(node, dict):
            if e[0] == "set":
                node[e[2]] = e[3]
            else:
                node.pop(e[2], None)
    return doc


TEXT_EDITS = st.one_of(
    st.tuples(st.just("insert"), st.integers(0, 2000), st.sampled_from(
        ["=", "[", "]]", "\n[[parity]]\n", '"', "\x00", "\ufeff", "#", "\n= 1\n", "{"])),
    st.tuples(st.just("cut"), st.integers(0, 2000), st.integers(1, 40)),
    st.tuples(st.just("append"), st.just(0), st.sampled_from(
        ['\n[import]\ncomplete_only = "true"\n', "\n[campaign]\nnu_hz = 1\n",
         '\n[[parity]]\nfiles = "results/**/*.h5"\n', "\n\n\n", "\n" + "a = 1\n" * 3])))


def _text_edit(text: str, op) -> str:
    kind, at, what = op
    at = at % (len(text) + 1)
    if kind == "insert":
        return text[:at] + what + text[at:]
    if kind == "cut":
        return text[:at] + text[at + what:]
    return text + what


@st.composite
def mapping_texts(draw):
    """The TOML text of an edited small-lab mapping (module doc)."""
    doc = edited(draw(st.lists(edits(), min_size=1, max_size=3)))
    text = toml_text(doc)
    if draw(st.integers(0, 7)) == 0:
        text = _text_edit(text, draw(TEXT_EDITS))
    return text
