"""A campaign folder written as ARTIQ results files (HDF5, laid out as ARTIQ and ndscan do).

Two differently shaped sets, each with the mapping (TOML) from which dpdfit's
importer rebuilds the tables: :func:`write_ndscan_campaign` (ndscan scans, bit
for bit) and :func:`write_per_shot_campaign` (per-shot outcomes, phases in turns,
plain gate-rate datasets, an old-ndscan file, an interrupted scan).  A value is
stored in SI units with the ``unit``/``scale`` of its display unit only when
``stored / scale`` gives it back bit for bit, else in its documented unit with
scale 1.  h5py is imported only when a file is written.
"""

from __future__ import annotations

import itertools
import json
import math
import re
import tomllib
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pandas as pd

from dpdfit.errors import DpdfitError

__all__ = ["ARTIQ_VERSION", "MAPPINGS", "pyon_encode", "axis", "channel", "ndscan_datasets",
           "write_results_file", "write_ndscan_campaign", "write_per_shot_campaign"]

#: Version string written as ``artiq_version``.
ARTIQ_VERSION = "8.0+unknown.beta"
#: Folder of the annotated mapping files copied next to the results.
# package data (pyproject.toml), so the writer works from an installed dpdfit too;
# examples/import/ links to these files
MAPPINGS = Path(__file__).resolve().parent / "artiq_mappings"
_TABLES = ("calibration_amplitude", "calibration_phase", "spectra", "populations", "parity",
           "time_scans", "gate_rates")
_RECORDED = ("spectra_recorded", "gates_recorded")
_MARK = ("# >>> campaign", "# <<< campaign")


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


def _epoch(iso: str) -> float:
    return datetime.fromisoformat(iso).timestamp()


class _Lab:
    """A campaign's tables, and the runs written from them into ``out`` (rids in order)."""

    def __init__(self, campaign_dir, out):
        folder = Path(campaign_dir)
        self.t = {n: pd.read_csv(folder / f"{n}.csv", comment="#") for n in _TABLES}
        self.campaign = json.loads((folder / "campaign.json").read_text())
        self.out, self.rid = Path(out), 0

    def run(self, class_name, start, datasets, arguments=None, metadata=None):
        self.rid += 1
        write_results_file(self.out, self.rid, class_name, start, datasets, arguments=arguments,
                           metadata=metadata)

    def scan(self, fqn, start, axes, channels, arguments=None, overrides=None, repeats=1, **kw):
        """An ndscan run of fragment ``fqn``; ``overrides``: parameter name -> value."""
        rid = self.rid + 1
        over = {f"{fqn}.{k}": [{"path": "*", "value": v}] for k, v in (overrides or {}).items()}
        gens = [{"type": "list", "fqn": f"{fqn}.{a['name']}", "path": "*",
                 "range": {"values": list(dict.fromkeys(a["values"].tolist()))}} for a in axes]
        scan = {"axes": gens, "num_repeats": repeats, "randomise_order_globally": False}
        params = {"instances": {"": [fqn]}, "scan": scan, "overrides": over}
        ds = ndscan_datasets(rid, fqn, axes, channels, seed=rid * 7919 % 2**31, **kw)
        self.run(fqn.rsplit(".", 1)[1], start, ds, {"ndscan_params": params, **(arguments or {})})


def _si(values, factor: float):
    """(stored, scale): ``values * factor`` if dividing by ``factor`` gives them back exactly."""
    x = np.asarray(values, dtype=float)
    stored = x * factor
    return (stored, factor) if np.array_equal(stored / factor, x, equal_nan=True) else (x, 1.0)


def _calibrations(lab: _Lab, percent: bool) -> None:
    """One run per calibration run (amplitude runs first: rid = run number), at its timestamp;
    with ``percent`` the amplitude calibration's axis is in % (if that round-trips exactly)."""
    percent = percent and _si(lab.t["calibration_amplitude"]["A"], 100.0)[1] == 100.0
    for table, fqn in (("calibration_amplitude", "lab.calib.AmplitudeCalibration"),
                       ("calibration_phase", "lab.calib.PhaseCalibration")):
        runs = lab.t[table].groupby("run", sort=False)
        for label, rows in sorted(runs, key=lambda r: _epoch(r[1]["timestamp"].iloc[0])):
            ax = axis("amplitude", rows["A"].to_numpy(float))
            if table == "calibration_amplitude":
                if percent:
                    ax = axis("amplitude", ax["values"] * 100.0, unit="%")
                ch = {"pd_power": channel(rows["power"]),
                      "pd_power_err": channel(rows["power_err"])}
            else:
                ch = {"phase": channel(rows["phase_rad"], "rad"),
                      "phase_err": channel(rows["phase_err"], "rad")}
            lab.scan(fqn, _epoch(rows["timestamp"].iloc[0]), [ax], ch, {"label": label})


def _spectra(lab: _Lab, per_amplitude: bool, step: float) -> None:
    """One file per dpd (amplitude an axis, dpd an argument) or per (A, dpd) (amplitude an
    argument, dpd a parameter override); axes sideband x order.  A spectrum recorded
    again (repeated rows of a tone) is a further run, after the first: the import reads
    the runs in that order, so the k-th row of a tone is again its k-th repeat."""
    clock = itertools.count(_epoch(lab.campaign["spectra_recorded"]), step)
    cols = (("tone_power", "P_dB", "dB"), ("valid", "valid", ""), ("snr", "snr_db", "dB"))
    sp = lab.t["spectra"]
    rep = sp.groupby(["A", "dpd", "sideband", "n"], sort=False).cumcount().rename("_repeat")
    keys = (["A", "dpd"] if per_amplitude else ["dpd"])
    for key, rows in sp.groupby([sp[k] for k in keys] + [rep]):
        key = key[:-1]
        axes = [axis("sideband", (rows["sideband"] == "blue").to_numpy(np.int64)),
                axis("order", rows["n"].to_numpy(np.int64))]
        ch = {name: channel(rows[col], unit) for name, col, unit in cols if col in rows}
        args, over = {"amplitude": float(key[0])}, {"dpd": int(key[-1])}
        if not per_amplitude:
            args, over = over, None
            axes.insert(0, axis("amplitude", rows["A"].to_numpy(float)))
        lab.scan("lab.spectra.HeterodyneSpectrum", next(clock), axes, ch, args, over)


def _duration(rows: pd.DataFrame) -> dict:
    stored, scale = _si(rows["t_us"], 1e-6)
    return axis("duration", stored, unit="us", scale=scale)


def _time_scan_runs(lab: _Lab):
    """The time scans, one run per (A, dpd) and repeat: a point recorded again (the same
    ``A, dpd, t_us``) belongs to a further run, as a lab repeats a scan."""
    ts = lab.t["time_scans"]
    rep = ts.groupby(["A", "dpd", "t_us"], sort=False).cumcount().rename("_repeat")
    return ts.groupby([ts["A"], ts["dpd"], rep])


def _ints(rows: pd.DataFrame, cols) -> dict:
    return {c: channel(rows[c].to_numpy(np.int64)) for c in cols}


def _ndscan_gates(lab: _Lab) -> None:
    """Set 1's gate runs: gate rates, populations per dpd, parity and time scans per (A, dpd)."""
    clock = itertools.count(_epoch(lab.campaign["gates_recorded"]), 300.0)
    g, ch = lab.t["gate_rates"], {}
    for name, col in (("xi0", "xi0_khz"), ("xi0_err", "xi0_err_khz")):
        stored, scale = _si(g[col], 1e3)
        ch[name] = channel(stored, "kHz", scale)
    axes = [axis("amplitude", g["A"].to_numpy(float)), axis("dpd", g["dpd"].to_numpy(np.int64))]
    lab.scan("lab.gates.GateRateCalibration", next(clock), axes, ch)
    for dpd, rows in lab.t["populations"].groupby("dpd"):
        rows = rows.sort_values(["scan", "A"], kind="stable")
        lab.scan("lab.gates.PopulationScan", next(clock), [axis("amplitude", rows["A"])],
                 _ints(rows, ("n00", "n01_10", "n11", "n_even", "shots")), {"dpd": int(dpd)},
                 repeats=rows["scan"].nunique())
    for (a, dpd), rows in lab.t["parity"].groupby(["A", "dpd"]):
        rows = rows.sort_values("scan", kind="stable")
        lab.scan("lab.gates.ParityScan", next(clock), [axis("phase", rows["phase_rad"], "rad")],
                 _ints(rows, ("n_even", "shots")), {"amplitude": float(a), "dpd": int(dpd)},
                 repeats=rows["scan"].nunique())
    for (a, dpd, _), rows in _time_scan_runs(lab):
        if rows["shots"].nunique() != 1:
            raise DpdfitError(f"time_scans: shots vary at A = {a}, dpd = {dpd}; "
                              "the mapping expects them constant per (A, dpd)")
        args = {"amplitude": float(a), "dpd": int(dpd), "num_shots": int(rows["shots"].iloc[0])}
        lab.scan("lab.gates.TimeScan", next(clock), [_duration(rows)],
                 _ints(rows, ("n00", "n01_10", "n11")), args)


def write_ndscan_campaign(campaign_dir, out_dir) -> Path:
    """Write a campaign as ndscan scans that the import reproduces bit for bit.

    One file per calibration run (axis ``amplitude``), per dpd for spectra (axes
    ``amplitude``, ``sideband``, ``order``) and populations (axis ``amplitude``,
    the scans as repeats), per (A, dpd) for parity (axis ``phase``, rad) and time
    scans (axis ``duration``), one for the gate rates (axes ``amplitude``, ``dpd``).
    Returns the path of ``out_dir/mapping.toml`` (a copy of ``ndscan_campaign.toml``).
    """
    lab = _Lab(campaign_dir, out_dir)
    _calibrations(lab, percent=False)
    _spectra(lab, False, 240.0)
    _ndscan_gates(lab)
    return _copy_mapping("ndscan_campaign.toml", lab.campaign, out_dir)


def _bright_ions(counts: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Numbers of bright ions per shot (points x shots; -1 pads), shuffled; counts: of 0, 1, 2."""
    counts = np.asarray(counts, dtype=np.int64)
    out = np.full((len(counts), counts.sum(axis=1).max()), -1, dtype=np.int64)
    for i, c in enumerate(counts):
        out[i, :c.sum()] = rng.permutation(np.repeat([0, 1, 2], c))
    return out


def _parity_scan(lab: _Lab, start, rows, n_even, rng, **kw) -> None:
    """A parity scan in turns, per-shot outcomes (the even ones split at random into 0 and 2)."""
    shots, n_even = rows["shots"].to_numpy(np.int64), np.asarray(n_even, np.int64)
    n0 = rng.binomial(n_even, 0.5)
    ions = _bright_ions(np.stack([n0, shots - n_even, n_even - n0], axis=1), rng)
    turns = rows["phase_rad"].to_numpy(float) / (2 * math.pi)
    lab.scan("lab.gates.ParityScan", start, [axis("phase", turns, "turn")],
             {"bright_ions": channel(ions)}, {"amplitude": float(rows["A"].iloc[0])},
             {"dpd": int(rows["dpd"].iloc[0])}, **kw)


def _per_shot_gates(lab: _Lab, rng) -> None:
    """Set 2's gate runs: gate rates as plain datasets, per-shot populations, time scans, parity."""
    clock = itertools.count(_epoch(lab.campaign["gates_recorded"]), 180.0)
    g, meta = lab.t["gate_rates"], {}
    ds = {"gate_rate.A": g["A"].to_numpy(float), "gate_rate.dpd": g["dpd"].to_numpy(np.int64)}
    for name, col in (("xi0", "xi0_khz"), ("xi0_err", "xi0_err_khz")):
        ds[f"gate_rate.{name}"], scale = _si(g[col], 1e3)
        meta[f"gate_rate.{name}"] = {"unit": "kHz", "scale": scale}
    lab.run("GateRateCalibration", next(clock), ds, {}, meta)
    levels = ["n00", "n01_10", "n11"]
    for _, rows in lab.t["populations"].groupby("scan"):
        axes = [axis("amplitude", rows["A"].to_numpy(float)),
                axis("dpd", rows["dpd"].to_numpy(np.int64))]
        ions = _bright_ions(rows[levels].to_numpy(), rng)
        lab.scan("lab.gates.PopulationScan", next(clock), axes, {"bright_ions": channel(ions)})
    for (a, dpd, _), rows in _time_scan_runs(lab):
        ions = _bright_ions(rows[levels].to_numpy(), rng)
        lab.scan("lab.gates.TimeScan", next(clock), [_duration(rows)],
                 {"bright_ions": channel(ions)}, {"amplitude": float(a), "dpd": int(dpd)})
    parity = lab.t["parity"]
    for k, (_, rows) in enumerate(parity.groupby(["A", "dpd", "scan"])):
        _parity_scan(lab, next(clock), rows, rows["n_even"], rng, legacy=k == 0)
    settings = parity.groupby(["A", "dpd"]).size().index          # interrupted: an extra repeat
    a, dpd = settings[len(settings) // 2]                          # of the middle setting's first
    rows = parity[(parity["A"] == a) & (parity["dpd"] == dpd)]     # scan, half of its phases
    rows = rows[rows["scan"] == rows["scan"].min()]
    rows = rows.iloc[: (len(rows) + 1) // 2]
    shots = rows["shots"].to_numpy(np.int64)
    n_even = rng.binomial(shots, rows["n_even"].to_numpy(float) / shots)
    _parity_scan(lab, next(clock), rows, n_even, rng, completed=False)


def write_per_shot_campaign(campaign_dir, out_dir, seed: int = 0) -> Path:
    """Write a campaign as a differently shaped lab would (see the module docstring).

    Spectra: one file per (A, dpd) (axes ``sideband``, ``order``; ``amplitude``
    argument, ``dpd`` an ndscan parameter override).  Populations: one file per
    scan (axes ``amplitude``, ``dpd``); time scans: one per (A, dpd); parity: one
    per (A, dpd, scan) (axis ``phase`` in turns), the first with the old root
    ``ndscan.``, plus an interrupted repeat; all with the per-shot channel
    ``bright_ions`` (shuffled with ``seed``).  Gate rates: plain datasets
    ``gate_rate.*``.  The amplitude calibration's axis is in percent.
    Returns ``out_dir/mapping.toml`` (a copy of ``per_shot_campaign.toml``).
    """
    lab = _Lab(campaign_dir, out_dir)
    _calibrations(lab, percent=True)
    _spectra(lab, True, 60.0)
    _per_shot_gates(lab, np.random.default_rng(seed))
    return _copy_mapping("per_shot_campaign.toml", lab.campaign, out_dir)


def _toml_table(name: str, table: dict) -> list:
    """TOML lines of a table of strings, finite numbers, booleans, lists and nested tables."""
    key = lambda k: k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else json.dumps(k)  # noqa: E731
    lines = [f"[{name}]"]
    lines += [f"{key(k)} = {json.dumps(v)}" for k, v in table.items() if not isinstance(v, dict)]
    for k, v in table.items():
        if isinstance(v, dict):
            lines += ["", *_toml_table(f"{name}.{key(k)}", v)]
    return lines


def _copy_mapping(name: str, campaign: dict, out_dir) -> Path:
    """Copy mapping ``name`` to ``out_dir/mapping.toml``; its [campaign] block (between the
    marker lines) is replaced by the campaign's keys when they differ."""
    source = MAPPINGS / name
    if not source.is_file():
        raise DpdfitError(f"mapping file {source} not found (it ships with dpdfit as package data)")
    text = source.read_text()
    wanted = {k: v for k, v in campaign.items() if k not in _RECORDED}
    if tomllib.loads(text).get("campaign") != wanted:
        head, rest = text.split(_MARK[0], 1)
        block, tail = rest.split(_MARK[1], 1)
        first = block.split("\n", 1)[0]
        lines = [head + _MARK[0] + first, *_toml_table("campaign", wanted), _MARK[1] + tail]
        text = "\n".join(lines)
    out = Path(out_dir, "mapping.toml")
    out.write_text(text)
    return out
