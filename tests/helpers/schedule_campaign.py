"""A small campaign written from scratch, for what a schedule takes from a campaign.

:func:`write_lab_campaign` writes the tables a schedule reads (``campaign.json``, the two
calibration tables, ``parity.csv``, ``time_scans.csv``) with what the bundled campaign
cannot vary: its own number of parity phases, a time scan of any number of times from
``t = 0``, and calibration runs at chosen starts (or without timestamps).  The counts are
plausible but not the point: nothing here is diagnosed.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

#: the calibration runs' grid (a coarse one: the schedule repeats whatever the latest has)
GRID = np.linspace(0.0, 1.0, 11)
#: the first run's start
T0 = pd.Timestamp("2025-03-03T08:00:00Z")
#: the gate setting of the parity scans and of the time scan
PARITY_SETTING = (0.6, 0)
TIME_SCAN_SETTING = (0.5, 1)


def _runs(starts, column: str, value) -> pd.DataFrame:
    parts = []
    for k, t in enumerate(starts):
        part = pd.DataFrame({"run": f"R{k + 1:03d}", "A": GRID, column: value(GRID),
                             f"{column}_err": 0.01})
        if t is not None:
            part.insert(1, "timestamp", (T0 + t).isoformat())
        parts.append(part)
    return pd.concat(parts, ignore_index=True)


def write_lab_campaign(folder: Path, *, parity_phases: int = 8, time_points: int = 31,
                       amplitude_gaps=(pd.Timedelta(days=2), pd.Timedelta(days=2),
                                       pd.Timedelta(days=2, hours=12)),
                       phase_gaps=(pd.Timedelta(minutes=30),) * 3,
                       timestamps: bool = True) -> Path:
    """``folder`` holding the small campaign (module doc).

    Parameters
    ----------
    parity_phases : int
        ``campaign.json``'s ``parity_phases``, and the phases of the parity scan at
        :data:`PARITY_SETTING` (one scan of 625 shots per phase).
    time_points : int
        The time scan's times at :data:`TIME_SCAN_SETTING`, ``t = 0`` included.
    amplitude_gaps, phase_gaps : sequence of Timedelta
        The gaps between the starts of consecutive runs of each calibration (one run
        more than gaps; the phase runs start on the last amplitude run's day).
    timestamps : bool
        Whether the runs carry their starts (without: no ``timestamp`` column).
    """
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "campaign.json").write_text(json.dumps({"name": "schedule test",
                                                      "parity_phases": parity_phases}))
    amp = np.concatenate([[0.0], np.cumsum(amplitude_gaps)]) if amplitude_gaps else [0]
    amp = [pd.Timedelta(t) if timestamps else None for t in amp]
    last = amp[-1] or pd.Timedelta(0)
    ph = [last + pd.Timedelta(t) if timestamps else None
          for t in np.concatenate([[pd.Timedelta(hours=1)],
                                   pd.Timedelta(hours=1) + np.cumsum(phase_gaps)])]
    _runs(amp, "power", lambda A: np.sin(np.pi * A / 2) ** 2).to_csv(
        folder / "calibration_amplitude.csv", index=False)
    _runs(ph, "phase_rad", lambda A: 0.1 * A ** 2).rename(
        columns={"phase_rad_err": "phase_err"}).to_csv(folder / "calibration_phase.csv",
                                                      index=False)
    A, d = PARITY_SETTING
    phases = np.arange(parity_phases) * 2 * np.pi / parity_phases
    pd.DataFrame({"A": A, "dpd": d, "scan": 1, "phase_rad": phases,
                  "n_even": (300 + 250 * np.cos(2 * phases)).round().astype(int),
                  "shots": 625}).to_csv(folder / "parity.csv", index=False)
    A, d = TIME_SCAN_SETTING
    t = np.linspace(0.0, 150.0, time_points)
    n11 = (625 * np.sin(np.pi * t / 300) ** 2).round().astype(int)
    pd.DataFrame({"A": A, "dpd": d, "t_us": t, "n00": 625 - n11, "n01_10": 0, "n11": n11,
                  "shots": 625}).to_csv(folder / "time_scans.csv", index=False)
    return folder
