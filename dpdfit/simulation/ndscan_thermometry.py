"""The sideband thermometry (``thermometry.csv``) as the ndscan runs a lab records it.

One run of :data:`THERMOMETRY_EXPERIMENT` per recording: two scan axes, ``wait`` (the
wait after cooling, stored in s with the display unit ``us``, as ndscan stores a
duration) and ``sideband`` (an integer code, :data:`SIDEBAND_CODES`: ``0`` red, ``1``
blue, which the mapping's ``labels`` turn back into the text ``thermometry.csv``
records), the bright counts the result channel ``n_bright`` and the shots the argument
``num_shots``.  The shipped mapping's ``[[thermometry]]`` imports them
(``dpdfit/simulation/artiq_mappings/ndscan_campaign.toml``).
"""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd

from dpdfit.errors import DpdfitError
from dpdfit.simulation.artiq_results_file import axis, stored_in_si
from dpdfit.simulation.ndscan_lab import NdscanLab, count_channels

__all__ = ["THERMOMETRY_EXPERIMENT", "SIDEBAND_CODES", "sideband_code", "thermometry_runs",
           "write_thermometry_runs", "write_campaign_thermometry_runs"]

#: the ndscan fragment of the lab's sideband thermometry (its results files end
#: ``-SidebandThermometry.h5``)
THERMOMETRY_EXPERIMENT = "lab.characterisation.SidebandThermometry"
#: the sideband axis's integer codes
SIDEBAND_CODES = {"red": 0, "blue": 1}


def sideband_code(sidebands) -> np.ndarray:
    """The sidebands (``red``, ``blue``) as the codes of the axis ``sideband``."""
    text = pd.Series(sidebands).astype(str).str.strip().str.lower()
    bad = [s for s in text if s not in SIDEBAND_CODES]
    if bad:
        raise DpdfitError(f"thermometry: sideband {bad[0]!r} is not red or blue")
    return np.array([SIDEBAND_CODES[s] for s in text], dtype=np.int64)


def thermometry_runs(rows: pd.DataFrame) -> list:
    """The thermometry rows as the runs a lab records them in, in order: a run probes each
    (wait, sideband) once with one number of shots, so a point probed again (or other
    shots) begins the next run.  Each run's rows, consecutive as in ``rows``."""
    if not len(rows):
        return []
    keys = list(zip(rows["wait_us"].to_numpy(float), sideband_code(rows["sideband"])))
    shots = rows["shots"].to_numpy(np.int64)
    starts, seen = [0], set()
    for i, (k, n) in enumerate(zip(keys, shots)):
        if k in seen or (i and n != shots[starts[-1]]):
            starts.append(i)
            seen = set()
        seen.add(k)
    return [rows.iloc[a:b] for a, b in zip(starts, starts[1:] + [len(rows)])]


def write_thermometry_runs(lab: NdscanLab, clock) -> None:
    """One run of :data:`THERMOMETRY_EXPERIMENT` per recording (:func:`thermometry_runs`)
    of ``lab.t['thermometry']``, started at the times ``clock`` gives (module doc)."""
    for rows in thermometry_runs(lab.t["thermometry"]):
        stored, scale = stored_in_si(rows["wait_us"], 1e-6)
        axes = [axis("wait", stored, unit="us", scale=scale),
                axis("sideband", sideband_code(rows["sideband"]))]
        lab.scan(THERMOMETRY_EXPERIMENT, next(clock), axes,
                 count_channels(rows, ("n_bright",)), {"num_shots": int(rows["shots"].iloc[0])})


def write_campaign_thermometry_runs(lab: NdscanLab) -> None:
    """The campaign's thermometry recordings (``thermometry.csv``, if it has one), 300 s
    apart after its last run."""
    if len(lab.t["thermometry"]):
        write_thermometry_runs(lab, itertools.count(lab.last + 300.0, 300.0))
