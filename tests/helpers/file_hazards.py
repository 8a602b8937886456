"""What a file received from elsewhere may hold in its place or in its contents, made on
disk, and Hypothesis strategies that draw it.

A :class:`Hazard` is put in the place of one input file of a command (:func:`put`):

* in the file's place (any kind of file): a symbolic link to a secret outside the
  folder, to a folder outside, to ``/dev/zero``; a FIFO; a character device (the one
  ``/dev/zero`` is; only as root); a sparse file beyond the size bound; a symbolic link
  loop;
* in a CSV table: a row wider than its header, a column named twice, a NUL byte, a cell
  a spreadsheet would run as a formula (``=``, ``+``, ``-``, ``@``), a number ``nan``,
  empty or ``1e400``, the file cut inside a line, bytes that are not UTF-8;
* in JSON: a NUL byte, cut, not UTF-8, nested deeply, a value of the wrong type (a list
  where text was, a number where a list was, ...);
* in TOML: a NUL byte, cut, not UTF-8, nested deeply;
* in a binary file (HDF5, ``.npz``): a byte flipped, cut;
* in place of a folder the command is given: a link loop, a FIFO, a device, a link to
  ``/dev/zero`` or to a folder outside, a regular file.

:func:`outside` writes the folder of secrets the links point at, each holding
:data:`~tests.helpers.untrusted_campaign.SECRET`, which no command may print or copy.
The sizes of the sparse files are drawn around :data:`BOUND`, the bound a test sets for
one run with ``DPDFIT_MAX_INPUT_BYTES`` (:data:`BOUND_ENV`), so that the honest files
lie within it and a file beyond it costs nothing to make.
"""

from __future__ import annotations

import json
import os
import shutil
import stat
from dataclasses import dataclass
from pathlib import Path

from hypothesis import strategies as st

from dpdfit.core.defaults import MAX_INPUT_BYTES_VARIABLE, MAX_JSON_BYTES
from tests.helpers.untrusted_campaign import SECRET

__all__ = [
    "BAD_NUMBERS",
    "BOUND",
    "BOUND_ENV",
    "CONTENT",
    "FOLDER",
    "FORMULAS",
    "PLACE",
    "Hazard",
    "hazards",
    "outside",
    "put",
    "wrong_type_targets",
]

#: the size bound set for one run: above every honest input of the tests, far below the
#: default of 1 GiB
BOUND = 1 << 20
#: the environment that sets it
BOUND_ENV = {MAX_INPUT_BYTES_VARIABLE: str(BOUND)}

#: cells a spreadsheet would run (OWASP "CSV injection"), none a number
FORMULAS = ("=cmd|' /C calc'!A0", "+cmd|' /C calc'!A0", "-2+3+cmd|' /C calc'!A0",
            "@SUM(1+1)*cmd|' /C calc'!A0", "=1+1", "=HYPERLINK(\"http://x\")")
#: numbers no recording holds
BAD_NUMBERS = ("nan", "NaN", "", "1e400", "-1e400", "inf")
_SPARSE_SIZES = (BOUND + 1, 4 * BOUND, 3 << 30)
_JSON_SPARSE_SIZES = (MAX_JSON_BYTES + 1, 3 << 30)
_DEPTHS = (1_000, 100_000)

#: hazards in a file's place, any kind of file
PLACE = ("link to a secret outside", "link to a folder outside", "link to /dev/zero",
         "FIFO", "device", "sparse file beyond the bound", "symbolic link loop")
#: hazards in a file's contents, by kind of file
CONTENT = {
    "csv": ("row wider than its header", "column named twice", "NUL byte", "formula cell",
            "number nan, empty or 1e400", "cut inside a line", "not UTF-8"),
    "json": ("NUL byte", "cut inside a line", "not UTF-8", "nested deeply", "wrong type"),
    "toml": ("NUL byte", "cut inside a line", "not UTF-8", "nested deeply"),
    "binary": ("byte flipped", "cut inside a line"),
    "any": (),
    "absent": (),
}
#: hazards in place of a folder a command is given
FOLDER = ("symbolic link loop", "FIFO", "device", "link to /dev/zero",
          "link to a folder outside", "regular file")

_SECRET_FILE = {"csv": "secret.csv", "json": "secret.json", "toml": "secret.toml"}


def _can_make_devices() -> bool:
    return hasattr(os, "mknod") and hasattr(os, "geteuid") and os.geteuid() == 0


@dataclass(frozen=True)
class Hazard:
    """One hazard (module doc): ``name``, ``at`` (which row, column, byte or key, taken
    modulo what the file has) and ``value`` (the cell, size, depth or value put there)."""

    name: str
    at: int = 0
    value: object = None

    def __repr__(self) -> str:
        return f"Hazard({self.name!r}, at={self.at}, value={self.value!r})"


def _values(name: str, kind: str):
    if name == "formula cell":
        return st.sampled_from(FORMULAS)
    if name == "number nan, empty or 1e400":
        return st.sampled_from(BAD_NUMBERS)
    if name == "sparse file beyond the bound":
        return st.sampled_from(_JSON_SPARSE_SIZES if kind == "json" else _SPARSE_SIZES)
    if name == "nested deeply":
        return st.sampled_from(_DEPTHS)
    if name == "wrong type":
        return st.integers(0, 7)
    return st.none()


def hazards(kind: str, names=None):
    """A strategy of the hazards for a file of ``kind`` (``"csv"``, ``"json"``,
    ``"toml"``, ``"binary"``; ``"any"``: a file whose contents no command reads;
    ``"absent"``: a file the folder may hold and does not; ``"folder"``: a folder given
    to the command), or of ``names`` among them."""
    if names is None:
        names = FOLDER if kind == "folder" else PLACE + CONTENT[kind]
    if not _can_make_devices():
        names = tuple(n for n in names if n != "device")
    return st.sampled_from(tuple(names)).flatmap(
        lambda n: st.builds(Hazard, st.just(n), st.integers(0, 10**6), _values(n, kind)))


# ----------------------------------------------------------------------------- the secrets


def outside(root: Path) -> Path:
    """``root/outside``: ``secret.csv``, ``.json``, ``.toml``, ``.txt`` and ``.h5`` (when
    h5py is there), each holding :data:`SECRET`, and a folder ``private`` holding it in
    ``id_rsa``; what is there already is kept (the secrets of
    :func:`~tests.helpers.untrusted_campaign.small_campaign`)."""
    out = Path(root) / "outside"
    (out / "private").mkdir(parents=True, exist_ok=True)
    texts = {"secret.csv": f"{SECRET},A,dpd\n{SECRET},0.5,0\n",
             "secret.json": f'{{"{SECRET}": 1}}\n',
             "secret.toml": f'[{SECRET}]\nkey = "{SECRET}"\n',
             "secret.txt": f"{SECRET}\n", "private/id_rsa": f"{SECRET}\n"}
    for name, text in texts.items():
        if not (out / name).exists():
            (out / name).write_text(text)
    try:
        import h5py
    except ImportError:
        return out
    if not (out / "secret.h5").exists():
        with h5py.File(out / "secret.h5", "w") as h5:
            h5["/datasets/secret"] = SECRET
    return out


# ----------------------------------------------------------------------------- making them


def put(path: Path, hazard: Hazard, kind: str, secrets: Path, keys=None) -> None:
    """``hazard`` in the place, or in the contents, of the file (or folder) ``path``, of
    ``kind`` (:func:`hazards`); ``secrets``: the folder of :func:`outside`; ``keys``: the
    keys of a JSON file (dotted: ``"predistortion_table.order"``) whose values, and the
    values under them, a ``"wrong type"`` may replace (default: any key)."""
    path = Path(path)
    if hazard.name in _PLACED:
        _clear(path)
        _PLACED[hazard.name](path, hazard, kind, secrets)
        return
    data = path.read_bytes()
    if hazard.name == "wrong type":
        path.write_bytes(_wrong_type(data, hazard, keys))
    else:
        path.write_bytes(_CONTENT[hazard.name](data, hazard))


def _clear(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    elif os.path.lexists(path):
        path.unlink()


def _link_secret(path, hazard, kind, secrets):
    target = secrets / _SECRET_FILE.get(kind, "secret.h5" if kind == "binary" else
                                        "secret.txt")
    os.symlink(target if target.exists() else secrets / "secret.txt", path)


def _sparse(path, hazard, kind, secrets):
    with open(path, "wb") as fh:
        fh.truncate(int(hazard.value))


def _loop(path, hazard, kind, secrets):
    other = path.with_name(path.name + ".loop")
    os.symlink(other.name, path)
    os.symlink(path.name, other)


def _device(path, hazard, kind, secrets):
    os.mknod(path, stat.S_IFCHR | 0o644, os.makedev(1, 5))


def _regular_file(path, hazard, kind, secrets):
    path.write_text(f"{SECRET}\n")


_PLACED = {
    "link to a secret outside": _link_secret,
    "link to a folder outside": lambda p, h, k, s: os.symlink(s / "private", p),
    "link to /dev/zero": lambda p, h, k, s: os.symlink("/dev/zero", p),
    "FIFO": lambda p, h, k, s: os.mkfifo(p),
    "device": _device,
    "sparse file beyond the bound": _sparse,
    "symbolic link loop": _loop,
    "regular file": _regular_file,
}


# ----------------------------------------------------------------------------- CSV


def _table(data: bytes):
    """``(lines, header index, data row indices)`` of CSV bytes (comments, blanks aside)."""
    lines = data.split(b"\n")
    kept = [i for i, ln in enumerate(lines) if ln.strip() and not ln.startswith(b"#")]
    return lines, (kept[0] if kept else None), kept[1:]


def _wider_row(data: bytes, h: Hazard) -> bytes:
    lines, head, rows = _table(data)
    if not rows:
        return data + b"1," * (lines[head].count(b",") + 2) + b"1\n"
    i = rows[h.at % len(rows)]
    lines[i] = lines[i].rstrip(b"\r") + b",1"
    return b"\n".join(lines)


def _named_twice(data: bytes, h: Hazard) -> bytes:
    lines, head, _ = _table(data)
    names = lines[head].rstrip(b"\r").split(b",")
    k = h.at % len(names)
    names[(k + 1) % len(names)] = names[k]
    lines[head] = b",".join(names)
    return b"\n".join(lines)


def _cell(data: bytes, h: Hazard, numeric: bool) -> bytes:
    """A cell of a data row (a numeric one when ``numeric``) replaced by ``h.value``."""
    lines, _, rows = _table(data)
    if not rows:
        return data
    i = rows[h.at % len(rows)]
    cells = lines[i].rstrip(b"\r").split(b",")
    numbers = [k for k, c in enumerate(cells) if _is_float(c)] if numeric else []
    choice = numbers or list(range(len(cells)))
    cells[choice[(h.at // len(rows)) % len(choice)]] = str(h.value).encode()
    lines[i] = b",".join(cells)
    return b"\n".join(lines)


def _is_float(cell: bytes) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


# ----------------------------------------------------------------------------- any text


def _nul(data: bytes, h: Hazard) -> bytes:
    k = h.at % (len(data) + 1)
    return data[:k] + b"\0" + data[k:]


def _not_utf8(data: bytes, h: Hazard) -> bytes:
    k = h.at % (len(data) + 1)
    return data[:k] + b"\xff\xfe\x80" + data[k:]


def _cut(data: bytes, h: Hazard) -> bytes:
    """The file cut inside a line (never at a line's end: that would be a shorter honest
    file), or to nothing."""
    body = data.rstrip(b"\r\n")
    if not body:
        return b""
    k = h.at % len(body)
    while 0 < k < len(body) and body[k - 1:k] in (b"\n", b"\r"):
        k += 1
    return body[:k]


def _flip(data: bytes, h: Hazard) -> bytes:
    k = h.at % len(data)
    return data[:k] + bytes([data[k] ^ 0xFF]) + data[k + 1:]


def _nested(data: bytes, h: Hazard) -> bytes:
    depth = int(h.value)
    if data.lstrip().startswith(b"{"):          # JSON: a key nested deeply, first
        start = data.index(b"{") + 1
        rest = data[start:].lstrip()
        sep = b"" if rest.startswith(b"}") else b", "
        return (data[:start] + b'"nested": ' + b"[" * depth + b"]" * depth + sep
                + data[start:])
    return b"nested = " + b"[" * depth + b"]" * depth + b"\n" + data   # TOML: top level


# ----------------------------------------------------------------------------- JSON types

#: values of another type than the one a key holds (by the type held)
_WRONG = {
    str: ([["aom"]], 7, {"x": 1}, True, ["text"], 10**400),
    list: (7, "text", {"x": []}, True, [[[]]], 10**400),
    dict: ([], 7, "text", True, [{}], 10**400),
    bool: ("true", 2, [], {}, "false", 10**400),
    int: ("1", [], {}, 10**400, "nan", [1]),
    float: ("0.5", [], {}, 10**400, "inf", [0.5]),
}


def _key_paths(obj, prefix=()):
    """Every key path into nested objects and lists (lists: their first three items)."""
    items = (obj.items() if isinstance(obj, dict) else
             enumerate(obj[:3]) if isinstance(obj, list) else [])
    out = []
    for k, v in items:
        out.append((prefix + (k,), v))
        out.extend(_key_paths(v, prefix + (k,)))
    return out


def _aimed(path: tuple, keys) -> bool:
    """Whether a ``"wrong type"`` may aim at ``path``: any path without ``keys``, else a
    path that is one of the dotted ``keys`` or lies under one."""
    dotted = ".".join(map(str, path))
    return keys is None or any(dotted == k or dotted.startswith(k + ".") for k in keys)


def wrong_type_targets(obj, keys=None) -> list:
    """The key paths a ``"wrong type"`` aims at in the JSON value ``obj``, in the order
    its ``at`` counts them (with ``keys`` as :func:`put` takes them): a test that wants
    one names it by ``wrong_type_targets(obj).index(path)``."""
    return [p for p, v in _key_paths(obj) if v is not None and _aimed(p, keys)]


def _wrong_type(data: bytes, h: Hazard, keys=None) -> bytes:
    obj = json.loads(data)
    paths = wrong_type_targets(obj, keys)
    if not paths:
        return json.dumps(7).encode()
    path = paths[h.at % len(paths)]
    parent = obj
    for k in path[:-1]:
        parent = parent[k]
    value = parent[path[-1]]
    wrong = _WRONG[float if isinstance(value, float) else
                   bool if isinstance(value, bool) else type(value)]
    parent[path[-1]] = wrong[int(h.value) % len(wrong)]
    return json.dumps(obj, indent=1).encode()


_CONTENT = {
    "row wider than its header": _wider_row,
    "column named twice": _named_twice,
    "NUL byte": _nul,
    "formula cell": lambda d, h: _cell(d, h, numeric=False),
    "number nan, empty or 1e400": lambda d, h: _cell(d, h, numeric=True),
    "cut inside a line": _cut,
    "not UTF-8": _not_utf8,
    "nested deeply": _nested,
    "byte flipped": _flip,
}
