"""One ARTIQ results file (HDF5, laid out as ARTIQ and ndscan do) and the ndscan datasets in it.

:func:`write_results_file` writes a run's datasets with the ARTIQ 8 archive keys and
its PYON ``expid`` (:func:`pyon_encode`); :func:`ndscan_datasets` builds the datasets an
ndscan scan archives from its :func:`axis` and :func:`channel` values.  A value is
stored in SI units with the ``unit``/``scale`` of its display unit only when ``stored /
scale`` gives it back bit for bit (:func:`stored_in_si`).  h5py is imported only when a
file is written.
"""

from __future__ import annotations

import json
import re
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from dpdfit.errors import DpdfitError

__all__ = ["ARTIQ_VERSION", "pyon_encode", "axis", "channel", "ndscan_datasets",
           "write_results_file", "stored_in_si"]

#: Version string written as ``artiq_version``.
ARTIQ_VERSION = "8.0+unknown.beta"


def pyon_encode(value) -> str:
    """PYON text of dicts, lists, strings, numbers, booleans and None (as sipyco writes it)."""
    if value is None or isinstance(value, (bool, np.bool_)):
        return "null" if value is None else ("true" if value else "false")
    if isinstance(value, (int, float, np.integer, np.floating)):
        return repr(value.item() if isinstance(value, np.generic) else value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(pyon_encode(v) for v in value) + "]"
    if isinstance(value, dict):
        return ("{" + ", ".join(f"{pyon_encode(k)}: {pyon_encode(v)}" for k, v in value.items())
                + "}")
    raise TypeError(f"pyon_encode: unsupported type {type(value).__name__}")


def axis(name, values, unit: str = "", scale: float = 1.0) -> dict:
    """An ndscan scan axis: parameter ``name`` and its coordinate at every point."""
    return {"name": name, "values": np.asarray(values), "unit": unit, "scale": float(scale)}


def channel(values, unit: str = "", scale: float = 1.0) -> dict:
    """An ndscan result channel: float, int, or "opaque" (a 2-D array, points x shots)."""
    return {"values": np.asarray(values), "unit": unit, "scale": float(scale)}


def _kind(values: np.ndarray) -> str:
    return "opaque" if values.ndim > 1 else "int" if values.dtype.kind in "iu" else "float"


def _axis_desc(fqn: str, ax: dict) -> dict:
    """The ``axes`` entry of one axis (ndscan's parameter schema plus list-generator limits)."""
    kind, v = _kind(ax["values"]), ax["values"]
    spec = {"is_scannable": True, "scale": ax["scale"]}
    if kind == "float":
        spec["step"] = ax["scale"] / 10.0
    if ax["unit"]:
        spec["unit"] = ax["unit"]
    param = {"fqn": f"{fqn}.{ax['name']}", "description": ax["name"].replace("_", " "),
             "type": kind, "default": str(v[0].item()), "spec": spec, "explanation": ""}
    return {"param": param, "path": "*", "min": v.min().item(), "max": v.max().item()}


def _channel_desc(name: str, ch: dict) -> dict:
    kind = ch.get("type") or _kind(ch["values"])
    desc = {"path": name, "description": name.replace("_", " "), "type": kind}
    if kind not in ("opaque", "subscan"):
        desc.update(scale=ch["scale"], unit=ch["unit"])
    return desc


def ndscan_datasets(rid: int, fqn: str, axes: list, channels: dict, *, completed: bool = True,
                    legacy: bool = False, seed: int = 0) -> dict:
    """The datasets an ndscan scan of fragment ``fqn`` archives (name -> value).

    Parameters
    ----------
    rid : int
        Run id; the root prefix is ``ndscan.rid_<rid>.``, or ``ndscan.`` if ``legacy``
        (old ndscan: no schema revision, ``rid`` instead of ``source_id``, ``auto_fit``).
    axes, channels : list of :func:`axis`, dict of name -> :func:`channel`
        Coordinates and results of every point in acquisition order (axis fqn: ``fqn.<name>``).
    completed : bool
        False for an interrupted scan.
    """
    ds = {"completed": bool(completed), "fragment_fqn": fqn, "seed": int(seed),
          "annotations": "[]"}
    if legacy:
        ds.update(rid=int(rid), auto_fit="[]")
    else:
        ds.update(ndscan_schema_revision=2, source_id=f"rid_{rid}", online_analyses="{}",
                  analysis_results="{}")
    ds["axes"] = json.dumps([_axis_desc(fqn, a) for a in axes])
    ds["channels"] = json.dumps({n: _channel_desc(n, c) for n, c in channels.items()})
    ds.update({f"points.axis_{i}": a["values"] for i, a in enumerate(axes)})
    ds.update({f"points.channel_{n}": c["values"] for n, c in channels.items()})
    prefix = "ndscan." if legacy else f"ndscan.rid_{rid}."
    return {prefix + k: v for k, v in ds.items()}


def _h5py():
    try:
        import h5py
    except ImportError:
        raise DpdfitError("writing ARTIQ results files needs h5py: "
                          "pip install 'dpdfit[artiq]'") from None
    return h5py


def write_results_file(out_dir, rid: int, class_name: str, start_time: float, datasets: dict, *,
                       arguments: dict | None = None, metadata: dict | None = None,
                       file: str | None = None) -> Path:
    """Write ``results/<YYYY-MM-DD>/<HH>/<rid:09d>-<class_name>.h5`` (UTC) and return its path.

    ``datasets`` go under ``datasets/`` with the ARTIQ 8 attributes of ``metadata``
    (name -> {"unit": .., "scale": ..}); ``arguments`` into the PYON ``expid``.
    """
    h5py = _h5py()
    when = datetime.fromtimestamp(start_time, timezone.utc)
    path = Path(out_dir, "results", when.strftime("%Y-%m-%d"), when.strftime("%H"),
                f"{rid:09d}-{class_name}.h5")
    path.parent.mkdir(parents=True, exist_ok=True)
    module = re.sub(r"(?<!^)(?=[A-Z])", "_", class_name).lower()
    expid = {"class_name": class_name, "file": file or f"repository/{module}.py",
             "arguments": arguments or {}, "log_level": 30, "repo_rev": "3f1c2ab"}
    with h5py.File(path, "w") as f:
        group = f.create_group("datasets")
        for name, value in datasets.items():
            group[name] = value
            for key, val in (metadata or {}).get(name, {}).items():
                group[name].attrs[key] = val
        f.create_group("archive")
        for key, value in (("artiq_version", ARTIQ_VERSION), ("rid", int(rid)),
                           ("start_time", float(start_time)), ("run_time", start_time + 2.5),
                           ("expid", pyon_encode(expid))):
            f[key] = value
    return path



def stored_in_si(values, factor: float):
    """(stored, scale): ``values * factor`` if dividing by ``factor`` gives them back exactly."""
    x = np.asarray(values, dtype=float)
    stored = x * factor
    return (stored, factor) if np.array_equal(stored / factor, x, equal_nan=True) else (x, 1.0)

