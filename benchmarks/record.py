"""The JSON record every benchmark script writes with ``--json PATH``.

One rule for all scripts in ``benchmarks/``: they print their table as before, and
with ``--json PATH`` they also write one record to PATH (by convention
``benchmarks/<script name>.json``; the documentation's Benchmarks page renders those
files)::

    {"benchmark": "counts_speed",
     "description": "<first line of the script's docstring>",
     "command": "python benchmarks/counts_speed.py --json benchmarks/counts_speed.json",
     "date": "2026-11-26T12:00:00+00:00",              # UTC, when the record was written
     "machine": {"platform", "processor", "cores", "memory_gib", "load_average",
                 "python", "numpy", "dpdfit", "dpdfit_git"},
     "rows": [{"column [unit]": value, ...}, ...],      # the table the script prints
     "notes": ["...", ...]}                             # optional

A row may carry a ``"table"`` key: rows with the same value form one table of that
name (a script printing several tables keeps them in one ``rows`` list).  Numbers
are stored unrounded; non-finite floats become ``null``.

Nothing here measures anything: this module only describes the machine and writes
the file (atomically: a temporary file in the same folder, then a rename).
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import shlex
import subprocess
import sys
from pathlib import Path

from dpdfit.core.jsonable import to_jsonable
from dpdfit.recordings.outputs import atomic_write_text

ROOT = Path(__file__).resolve().parents[1]


def add_json_option(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Add the common ``--json PATH`` option to a script's parser."""
    parser.add_argument("--json", metavar="PATH", type=Path, default=None,
                        help="also write the results as one JSON record to PATH "
                             "(convention: benchmarks/<script name>.json)")
    return parser


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                key, _, value = line.partition(":")
                if key.strip() in ("model name", "Processor", "cpu model") and value.strip():
                    return value.strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def _memory_gib() -> float | None:
    try:
        with open("/proc/meminfo", encoding="utf-8") as fh:
            for line in fh:
                if line.startswith("MemTotal:"):
                    return round(int(line.split()[1]) / 2**20, 1)
    except (OSError, ValueError, IndexError):
        pass
    return None


def _git_describe() -> str | None:
    """Commit of the checkout the benchmark ran from (``+modified`` if it had edits)."""
    try:
        head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short=12", "HEAD"],
                              capture_output=True, text=True, timeout=10)
        if head.returncode:
            return None
        dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain",
                                "--untracked-files=no", "--", "dpdfit"],
                               capture_output=True, text=True, timeout=10)
        return head.stdout.strip() + ("+modified" if dirty.stdout.strip() else "")
    except (OSError, subprocess.SubprocessError):
        return None


def machine() -> dict:
    """What the benchmark ran on: platform, CPU model, cores, memory, versions, load."""
    import numpy

    try:
        import dpdfit
        version = dpdfit.__version__
    except Exception:               # noqa: BLE001  (a benchmark of a broken tree still records)
        version = None
    try:
        load = [round(x, 2) for x in os.getloadavg()]
    except OSError:
        load = None
    return {
        "platform": platform.platform(),
        "processor": _cpu_model(),
        "cores": os.cpu_count(),
        "memory_gib": _memory_gib(),
        "load_average": load,           # 1, 5, 15 min, when the record was written
        "python": platform.python_version(),
        "numpy": numpy.__version__,
        "dpdfit": version,
        "dpdfit_git": _git_describe(),
    }


def command_line(argv: list[str] | None = None) -> str:
    """The command as typed from the repository root: ``python benchmarks/x.py ...``."""
    argv = list(sys.argv if argv is None else argv)
    script = Path(argv[0]).resolve() if argv else Path("?")
    try:
        shown = str(script.relative_to(ROOT))
    except ValueError:
        shown = argv[0]
    return shlex.join(["python", shown, *argv[1:]])


def make_record(name: str, rows: list[dict], *, description: str = "",
                notes: list[str] | None = None, argv: list[str] | None = None) -> dict:
    """The record of one run (date taken now, in UTC)."""
    rec = {
        "benchmark": name,
        "description": description,
        "command": command_line(argv),
        "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "machine": machine(),
        "rows": to_jsonable(rows),
    }
    if notes:
        rec["notes"] = [str(n) for n in notes]
    return rec


def write_json(path: Path | str, data: dict) -> Path:
    """Write ``data`` to ``path`` atomically, non-finite floats as ``null``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # dpdfit's own converter and atomic writer; paths (in commands, notes) as text
    atomic_write_text(path, json.dumps(to_jsonable(data), indent=1, allow_nan=False,
                                       default=str) + "\n")
    return path


def write_record(path: Path | str | None, name: str, rows: list[dict], *,
                 description: str = "", notes: list[str] | None = None) -> dict | None:
    """Write the record to ``path`` (nothing when ``path`` is None); returns it."""
    if path is None:
        return None
    rec = make_record(name, rows, description=description, notes=notes)
    write_json(path, rec)
    print(f"(record written to {path})")
    return rec


def summary_line(doc: str | None) -> str:
    """The first paragraph of a docstring, on one line."""
    return " ".join((doc or "").strip().split("\n\n")[0].split())
