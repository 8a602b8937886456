"""Compare two `dpdfit analyze` results folders, ignoring timing fields.

    python scripts/compare_analyze.py RESULTS_BEFORE RESULTS_AFTER [--inputs-differ]

Tables (CSV) and JSON files must be identical value by value; keys that hold
wall-clock times or dates (``seconds``, ``*_seconds``, ``elapsed*``,
``wall_time*``, ``created``) and lines of ``summary.md`` that report times are
left out.  The figures must be
the same set of files (their pixels are not compared: fonts and the renderer
may differ between machines).  ``--inputs-differ``: the two analyses read
different copies of the recordings (e.g. a CSV campaign and the same campaign
imported from ARTIQ results files): the input files' paths and SHA-256
(``source`` keys, the summary's title) are left out too.  Exit status 0 when
identical, 1 otherwise, with one line per difference.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

TIMING_KEY = re.compile(r"(^|_)(seconds|elapsed|wall_time|time_s|created)($|_)")
TIMING_LINE = re.compile(r"\bin \d+(\.\d+)? s\b|\d+(\.\d+)? s\)|seconds")
INPUT_KEY = re.compile(r"^(source|campaign)$")
INPUT_LINE = re.compile(r"^# dpdfit analysis of ")


def _strip(obj, inputs: bool = False):
    if isinstance(obj, dict):
        return {k: _strip(v, inputs) for k, v in obj.items() if not TIMING_KEY.search(str(k))
                and not (inputs and INPUT_KEY.search(str(k)))}
    if isinstance(obj, list):
        return [_strip(v, inputs) for v in obj]
    return obj


def _diff(a, b, path=""):
    if type(a) is not type(b) and not (isinstance(a, (int, float)) and isinstance(b, (int, float))):
        return [f"{path}: {a!r} != {b!r}"]
    if isinstance(a, dict):
        out = [f"{path}.{k}: only in {'before' if k in a else 'after'}"
               for k in sorted(set(a) ^ set(b))]
        for k in sorted(set(a) & set(b)):
            out += _diff(a[k], b[k], f"{path}.{k}")
        return out
    if isinstance(a, list):
        if len(a) != len(b):
            return [f"{path}: length {len(a)} != {len(b)}"]
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in _diff(x, y, f"{path}[{i}]")]
    return [] if a == b or (a != a and b != b) else [f"{path}: {a!r} != {b!r}"]


def compare(before: Path, after: Path, inputs_differ: bool = False) -> list[str]:
    out = []
    files_a = {p.relative_to(before) for p in before.rglob("*") if p.is_file()}
    files_b = {p.relative_to(after) for p in after.rglob("*") if p.is_file()}
    out += [f"{f}: only in {before}" for f in sorted(files_a - files_b)]
    out += [f"{f}: only in {after}" for f in sorted(files_b - files_a)]
    for f in sorted(files_a & files_b):
        a, b = before / f, after / f
        if f.suffix == ".json":
            out += [f"{f}{d}" for d in _diff(_strip(json.loads(a.read_text()), inputs_differ),
                                              _strip(json.loads(b.read_text()), inputs_differ))]
        elif f.suffix in (".csv", ".md", ".txt"):
            skip = [TIMING_LINE] + ([INPUT_LINE] if inputs_differ else [])
            la = [x for x in a.read_text().splitlines() if not any(r.search(x) for r in skip)]
            lb = [x for x in b.read_text().splitlines() if not any(r.search(x) for r in skip)]
            if la != lb:
                n = next((i for i, (x, y) in enumerate(zip(la, lb)) if x != y), min(len(la), len(lb)))
                out.append(f"{f}: differs from line {n + 1}: "
                           f"{la[n] if n < len(la) else '<end>'!r} vs {lb[n] if n < len(lb) else '<end>'!r}")
    return out


def main(argv=None) -> int:
    args = sys.argv[1:] if argv is None else list(argv)
    inputs_differ = "--inputs-differ" in args
    args = [a for a in args if a != "--inputs-differ"]
    if len(args) != 2:
        print(__doc__.strip().splitlines()[2].strip(), file=sys.stderr)
        return 2
    diffs = compare(Path(args[0]), Path(args[1]), inputs_differ)
    for d in diffs:
        print(d)
    print("identical (timing fields aside)" if not diffs else f"{len(diffs)} differences")
    return 1 if diffs else 0


if __name__ == "__main__":
    sys.exit(main())
