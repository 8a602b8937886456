"""A campaign folder written as ARTIQ results files, with the mapping that imports it.

Two differently shaped sets, each with the mapping (TOML) from which dpdfit's
importer rebuilds the tables: :func:`write_ndscan_campaign` (ndscan scans, bit
for bit) and :func:`write_per_shot_campaign` (per-shot outcomes, phases in turns,
plain gate-rate datasets, an old-ndscan file, an interrupted scan).  The files
themselves are written by :mod:`dpdfit.simulation.artiq_results_file`, the runs
the two sets share by :mod:`dpdfit.simulation.ndscan_lab`; the mappings ship with
dpdfit (:data:`MAPPINGS`) and are copied with the campaign's constants
(:func:`copy_mapping`).
"""

from __future__ import annotations

import itertools
import json
import math
import re
import tomllib
from pathlib import Path

import numpy as np

from dpdfit.errors import DpdfitError
from dpdfit.simulation.artiq_results_file import axis, channel, stored_in_si
from dpdfit.simulation.ndscan_lab import (NdscanLab, duration_axis, epoch, time_scan_runs,
                                          write_calibration_runs,
                                          write_campaign_linearity_runs,
                                          write_campaign_pulse_runs,
                                          write_campaign_ramsey_runs,
                                          write_campaign_spam_runs,
                                          write_ndscan_gate_runs, write_spectra_runs)
from dpdfit.simulation.ndscan_thermometry import write_campaign_thermometry_runs

__all__ = ["MAPPINGS", "copy_mapping", "mapping_sources", "write_ndscan_campaign",
           "write_per_shot_campaign"]

#: Folder of the annotated mapping files copied next to the results.
# package data (pyproject.toml), so the writer works from an installed dpdfit too;
# examples/import/ links to these files
MAPPINGS = Path(__file__).resolve().parent / "artiq_mappings"
_RECORDED = ("spectra_recorded", "gates_recorded")
_MARK = ("# >>> campaign", "# <<< campaign")


def write_ndscan_campaign(campaign_dir, out_dir) -> Path:
    """Write a campaign as ndscan scans that the import reproduces bit for bit.

    One file per calibration run (axis ``amplitude``), per dpd for spectra (axes
    ``amplitude``, ``sideband``, ``order``) and populations (axis ``amplitude``,
    the scans as repeats), per (A, dpd) for parity (axis ``phase``, rad) and time
    scans (axis ``duration``), one for the gate rates (axes ``amplitude``, ``dpd``), and,
    when the campaign has ``spam.csv``, one per SPAM recording (axis ``prepared``, a
    code: :func:`~dpdfit.simulation.ndscan_lab.write_spam_runs`), with
    ``pulse_response.csv`` one per pulse-response trace (axis ``delay``:
    :func:`~dpdfit.simulation.ndscan_lab.write_pulse_runs`), with ``ramsey.csv`` one
    per Ramsey scan (axes ``sequence``, a code, and ``wait``:
    :func:`~dpdfit.simulation.ndscan_lab.write_ramsey_runs`) and with
    ``detector_linearity.csv`` one per linearity recording (axis ``amplitude``:
    :func:`~dpdfit.simulation.ndscan_lab.write_linearity_runs`), and with
    ``thermometry.csv`` one per thermometry recording
    (:func:`~dpdfit.simulation.ndscan_thermometry.write_thermometry_runs`).
    Returns the path of ``out_dir/mapping.toml`` (a copy of ``ndscan_campaign.toml``;
    without ``spam.csv`` its ``[[spam]]`` source is left out, a glob that would match
    no file, and so are ``[[pulse_response]]`` without ``pulse_response.csv``,
    ``[[ramsey]]`` without ``ramsey.csv`` and ``[[detector_linearity]]`` without
    ``detector_linearity.csv``).
    """
    lab = NdscanLab(campaign_dir, out_dir)
    write_calibration_runs(lab, percent=False)
    write_spectra_runs(lab, False, 240.0)
    write_ndscan_gate_runs(lab)
    write_campaign_spam_runs(lab)
    write_campaign_pulse_runs(lab)
    write_campaign_ramsey_runs(lab)
    write_campaign_linearity_runs(lab)
    write_campaign_thermometry_runs(lab)
    return copy_mapping("ndscan_campaign.toml", lab.campaign, out_dir,
                        [t for t, rows in lab.t.items()
                         if t not in ("spam", "pulse_response", "ramsey", "detector_linearity",
                                      "thermometry")
                         or len(rows)])


def _bright_ions(counts: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Numbers of bright ions per shot (points x shots; -1 pads), shuffled; counts: of 0, 1, 2."""
    counts = np.asarray(counts, dtype=np.int64)
    out = np.full((len(counts), counts.sum(axis=1).max()), -1, dtype=np.int64)
    for i, c in enumerate(counts):
        out[i, :c.sum()] = rng.permutation(np.repeat([0, 1, 2], c))
    return out


def _parity_scan(lab: NdscanLab, start, rows, n_even, rng, **kw) -> None:
    """A parity scan in turns, per-shot outcomes (the even ones split at random into 0 and 2)."""
    shots, n_even = rows["shots"].to_numpy(np.int64), np.asarray(n_even, np.int64)
    n0 = rng.binomial(n_even, 0.5)
    ions = _bright_ions(np.stack([n0, shots - n_even, n_even - n0], axis=1), rng)
    turns = rows["phase_rad"].to_numpy(float) / (2 * math.pi)
    lab.scan("lab.gates.ParityScan", start, [axis("phase", turns, "turn")],
             {"bright_ions": channel(ions)}, {"amplitude": float(rows["A"].iloc[0])},
             {"dpd": int(rows["dpd"].iloc[0])}, **kw)


def _per_shot_gates(lab: NdscanLab, rng) -> None:
    """Set 2's gate runs: gate rates as plain datasets, per-shot populations, time scans, parity."""
    clock = itertools.count(epoch(lab.campaign["gates_recorded"]), 180.0)
    g, meta = lab.t["gate_rates"], {}
    ds = {"gate_rate.A": g["A"].to_numpy(float), "gate_rate.dpd": g["dpd"].to_numpy(np.int64)}
    for name, col in (("xi0", "xi0_khz"), ("xi0_err", "xi0_err_khz")):
        ds[f"gate_rate.{name}"], scale = stored_in_si(g[col], 1e3)
        meta[f"gate_rate.{name}"] = {"unit": "kHz", "scale": scale}
    lab.run("GateRateCalibration", next(clock), ds, {}, meta)
    levels = ["n00", "n01_10", "n11"]
    for _, rows in lab.t["populations"].groupby("scan"):
        axes = [axis("amplitude", rows["A"].to_numpy(float)),
                axis("dpd", rows["dpd"].to_numpy(np.int64))]
        ions = _bright_ions(rows[levels].to_numpy(), rng)
        lab.scan("lab.gates.PopulationScan", next(clock), axes, {"bright_ions": channel(ions)})
    for (a, dpd, _), rows in time_scan_runs(lab):
        ions = _bright_ions(rows[levels].to_numpy(), rng)
        lab.scan("lab.gates.TimeScan", next(clock), [duration_axis(rows)],
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
    lab = NdscanLab(campaign_dir, out_dir)
    write_calibration_runs(lab, percent=True)
    write_spectra_runs(lab, True, 60.0)
    _per_shot_gates(lab, np.random.default_rng(seed))
    return copy_mapping("per_shot_campaign.toml", lab.campaign, out_dir)


def _toml_table(name: str, table: dict) -> list:
    """TOML lines of a table of strings, finite numbers, booleans, lists and nested tables."""
    key = lambda k: k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else json.dumps(k)  # noqa: E731
    lines = [f"[{name}]"]
    lines += [f"{key(k)} = {json.dumps(v)}" for k, v in table.items() if not isinstance(v, dict)]
    for k, v in table.items():
        if isinstance(v, dict):
            lines += ["", *_toml_table(f"{name}.{key(k)}", v)]
    return lines


def mapping_sources(text: str, tables) -> str:
    """A mapping's text with the sources (``[[table]]`` entries) of ``tables`` only: each
    source's block, from the comment paragraph above its header to the next one's, is
    kept or left out whole; the text before the first source is kept."""
    lines = text.split("\n")
    heads = [i for i, s in enumerate(lines) if s.startswith("[[")]
    if not heads:
        return text
    starts = []
    for i in heads:                  # a source's block begins with its comment paragraph
        while i > 0 and lines[i - 1].startswith("#"):
            i -= 1
        starts.append(i)
    keep = lines[:starts[0]]
    for k, (i, s) in enumerate(zip(heads, starts)):
        end = starts[k + 1] if k + 1 < len(starts) else len(lines)
        if lines[i].strip("[] ") in tables:
            keep += lines[s:end]
    return "\n".join(keep)


def copy_mapping(name: str, campaign: dict, out_dir, tables=None) -> Path:
    """Copy mapping ``name`` to ``out_dir/mapping.toml``; its [campaign] block (between the
    marker lines) is replaced by the campaign's keys when they differ; with ``tables``,
    only those tables' sources are kept (:func:`mapping_sources`)."""
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
    if tables is not None:
        text = mapping_sources(text, tables)
    out = Path(out_dir, "mapping.toml")
    out.write_text(text)
    return out
