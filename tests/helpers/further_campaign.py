"""A small simulated campaign, the same campaign with further recordings, and NEW's rows.

:func:`small_config` is the closed loop's reduced harness campaign (seconds to simulate);
:data:`FURTHER` lists one further recording of each kind the simulator adds
(:func:`dpdfit.simulation.further_recordings.extend_config`); :func:`added_rows` gives
the rows the extended campaign has beyond the campaign, table by table (the simulator
only appends), and :func:`write_new_folder` writes them as a folder of CSV files, with
the scan labels a lab's own numbering would give them (1, 2, ... per setting).
"""

from __future__ import annotations

import dataclasses
import io
from pathlib import Path

import pandas as pd

import dpdfit.simulation.harness as H
from dpdfit.simulation.campaign import simulate_campaign
from dpdfit.simulation.further_recordings import extend_config

SEED = 4242
#: one further recording of every kind: a run of each calibration, spectra (one
#: amplitude recorded again), a parity scan at a new setting (with its gate rate and
#: population row), two population scans at a setting the campaign has, a time scan
FURTHER = ({"what": "amplitude_run", "settings": {"runs": 1}},
           {"what": "phase_run", "settings": {"runs": 1}},
           {"what": "spectra", "settings": {"amplitudes": [0.6, 0.3], "dpd": [0, 1]}},
           {"what": "parity", "settings": {"A": 0.55, "dpd": 1, "shots": 16 * 300}},
           {"what": "populations", "settings": {"A": 0.4, "dpd": 0, "shots": 500,
                                                "scans": 2}},
           {"what": "time_scan", "settings": {"A": 0.4, "dpd": 1, "shots": 400,
                                              "points": 4}})


def small_config():
    """The harness campaign, reduced: one gate amplitude, one scan, four spectra amplitudes."""
    return dataclasses.replace(H.harness_config(SEED), gate_amplitudes=(0.4,),
                               time_scan_A=0.4, scan_shots=((300, 300),), time_scan_points=5,
                               trace_amplitudes=(0.2, 0.4, 0.6, 0.8), n_amp_runs=5,
                               runs_after_recordings=1, cal_points=41)


def simulate(folder: Path, further=()) -> Path:
    """The small campaign (with the ``further`` recordings) written to ``folder``."""
    cfg = small_config()
    for m in further:
        cfg = extend_config(cfg, m)
    simulate_campaign(folder, seed=SEED, config=cfg, progress=False)
    return folder


def added_rows(base: Path, ext: Path) -> dict:
    """table -> the rows ``ext`` has beyond ``base`` (as text tables; tables without)."""
    out = {}
    for p in sorted(base.glob("*.csv")):
        old, new = p.read_text(), (ext / p.name).read_text()
        assert new.startswith(old), p.name
        if new != old:
            header = old.split("\n", 1)[0]
            out[p.stem] = pd.read_csv(io.StringIO(header + "\n" + new[len(old):]), dtype=str,
                                      keep_default_na=False)
    return out


def lab_numbered(rows: dict) -> dict:
    """The rows with the scan labels a lab numbering its own new scans would give: the
    ranks 1, 2, ... of the simulator's labels per setting, over populations and parity."""
    out = dict(rows)
    labels = {}
    for t in ("populations", "parity"):
        if t in rows:
            for a, d, s in zip(rows[t]["A"], rows[t]["dpd"], rows[t]["scan"]):
                labels.setdefault((a, d), set()).add(int(s))
    rank = {(k, s): str(i + 1) for k, ss in labels.items() for i, s in enumerate(sorted(ss))}
    for t in ("populations", "parity"):
        if t in rows:
            df = rows[t].copy()
            df["scan"] = [rank[((a, d), int(s))] for a, d, s in
                          zip(df["A"], df["dpd"], df["scan"])]
            out[t] = df
    return out


def write_new_folder(folder: Path, rows: dict) -> Path:
    """The rows as a folder of CSV files (the campaign layout; no campaign.json)."""
    folder.mkdir(parents=True)
    for t, df in rows.items():
        df.to_csv(folder / f"{t}.csv", index=False, lineterminator="\n")
    return folder
