"""Output helpers at the edge of the package: atomic writes and file hashes.

Nothing dpdfit writes is ever half-written: every output goes to a temporary
file in the destination directory and is moved into place with
:func:`os.replace` (atomic on POSIX and Windows).  Groups of files are staged
together and only moved once all of them were written, so a failure leaves no
partial output behind.  Inputs are never overwritten: callers pass the input
paths and :func:`refuse_overwriting_inputs` raises if an output would land on
one of them.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import tempfile
from pathlib import Path
from typing import Callable, Iterable, Iterator

import numpy as np

from dpdfit.errors import InputError

__all__ = ["read_csv_header", "write_csv_with_header", "sha256_file", "refuse_overwriting_inputs", "staged_outputs",
           "atomic_write_text", "atomic_write_json", "to_jsonable"]


def sha256_file(path: str | os.PathLike) -> str:
    """Hex SHA-256 digest of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def refuse_overwriting_inputs(outputs: Iterable[str | os.PathLike],
                              inputs: Iterable[str | os.PathLike]) -> None:
    """Raise :class:`InputError` if any output path is one of the inputs."""
    ins = {Path(p).resolve() for p in inputs if p is not None}
    for out in outputs:
        if out is not None and Path(out).resolve() in ins:
            raise InputError("refusing to overwrite an input file; choose another output path",
                             file=str(out))


@contextlib.contextmanager
def staged_outputs() -> Iterator[Callable[[str | os.PathLike], Path]]:
    """Stage several output files and publish them together.

    Yields a function ``stage(final_path) -> temp_path``; write each output to
    the returned temporary path.  On normal exit every staged file is moved to
    its final path; on an exception all temporaries are removed and no final
    path is touched.
    """
    staged: list[tuple[Path, Path]] = []

    def stage(final: str | os.PathLike) -> Path:
        final = Path(final)
        final.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{final.name}.", suffix=".part",
                                   dir=final.parent)
        os.close(fd)
        staged.append((Path(tmp), final))
        return Path(tmp)

    try:
        yield stage
    except BaseException:
        for tmp, _ in staged:
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
        raise
    for tmp, final in staged:
        os.replace(tmp, final)


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` to ``path`` atomically."""
    with staged_outputs() as stage:
        stage(path).write_text(text)


def to_jsonable(obj):
    """Convert numpy scalars/arrays (recursively) to plain Python for JSON."""
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating):
        obj = float(obj)
    if isinstance(obj, float) and not np.isfinite(obj):
        return None  # JSON has no NaN/inf; absent values are null
    return obj


def atomic_write_json(path: str | os.PathLike, obj) -> None:
    """Serialise ``obj`` (numpy-aware) as indented JSON, atomically."""
    atomic_write_text(path, json.dumps(to_jsonable(obj), indent=2) + "\n")


def write_csv_with_header(path: str | os.PathLike, df, meta: dict) -> None:
    """Write a pandas table as CSV with ``# key: <json>`` provenance lines on top, atomically.

    Read it back with :func:`read_csv_with_header` (or
    ``pandas.read_csv(path, comment="#")`` for the table alone).
    """
    header = "".join(f"# {k}: {json.dumps(to_jsonable(v))}\n" for k, v in meta.items())
    atomic_write_text(path, header + df.to_csv(index=False, float_format="%.12g"))


def read_csv_header(path: str | os.PathLike) -> dict:
    """The ``# key: <json>`` lines at the top of a CSV file, as a dict."""
    meta = {}
    with open(path) as fh:
        for line in fh:
            if not line.startswith("#"):
                break
            key, sep, val = line[1:].partition(":")
            if not sep:
                continue
            try:
                meta[key.strip()] = json.loads(val.strip())
            except json.JSONDecodeError:
                meta[key.strip()] = val.strip()
    return meta
