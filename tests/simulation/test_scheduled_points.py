"""The stand-in refuses a schedule it would not record as written (an edited time, grid
point, phase or shot count), naming the schedule's row, and accepts the points it records
(with the extra rows a new setting brings)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from dpdfit.errors import InputError
from dpdfit.recordings.schedule import check_schedule
from dpdfit.simulation.scheduled_points import check_recorded_as_scheduled

TIMES = np.round(np.linspace(0, 150, 5), 6)


def _schedule(rows):
    df = pd.DataFrame(rows)
    for c in ("dpd", "shots", "phase_rad", "t_us", "lab_s"):
        df[c] = df.get(c, np.nan)
    return check_schedule(df)


def _recorded():
    ts = pd.DataFrame([{"A": 0.6, "dpd": 1, "t_us": t, "n00": 1, "n01_10": 0, "n11": 1,
                        "shots": 300} for _ in range(2) for t in TIMES])
    par = pd.DataFrame([{"A": 0.5, "dpd": 0, "scan": 1, "phase_rad": p, "n_even": 3,
                         "shots": 200} for p in np.arange(16) * np.pi / 8])
    pop = pd.DataFrame([{"A": 0.5, "dpd": 0, "scan": 1, "n00": 1, "n01_10": 0, "n11": 1,
                         "n_even": 2, "shots": 3200}])        # the new setting's populations
    tones = [("red", n) for n in range(-1, 5)] + [("blue", n) for n in range(-1, 5)]
    sp = pd.DataFrame([{"A": a, "dpd": d, "sideband": s, "n": n, "P_dB": -30.0}
                       for a in (0.3, 0.6) for d in (0, 1) for s, n in tones])
    return {"time_scans": ts, "parity": par, "populations": pop, "spectra": sp}


GOOD = ([{"kind": "time_scan", "repeat": r, "point": i, "A": 0.6, "dpd": 1, "shots": 300,
          "t_us": t} for r in (1, 2) for i, t in enumerate(TIMES)]
        + [{"kind": "parity", "repeat": 1, "point": i, "A": 0.5, "dpd": 0, "shots": 200,
            "phase_rad": p} for i, p in enumerate(np.arange(16) * np.pi / 8)]
        + [{"kind": "spectra", "repeat": 1, "point": k, "A": a, "dpd": d}
           for k, (a, d) in enumerate((a, d) for a in (0.3, 0.6) for d in (0, 1))])


def test_every_scheduled_point_recorded_passes():
    check_recorded_as_scheduled(_schedule(GOOD), _recorded())


@pytest.mark.parametrize("row,edit,column,named", [
    (3, {"t_us": 80.0}, "t_us", 4),                   # a time the simulator does not take
    (12, {"shots": 250}, "shots", 11),                # other shots per phase: the scan's first
    (12, {"phase_rad": 0.3}, "phase_rad", 13),
    (26, {"A": 0.35}, "A", 27),                       # a trace at another amplitude
])
def test_an_edited_point_is_refused_naming_its_row(row, edit, column, named):
    rows = [dict(r) for r in GOOD]
    rows[row].update(edit)
    if column == "shots":                             # shots constant within the scan
        for r in rows:
            if r["kind"] == "parity":
                r["shots"] = edit["shots"]
    with pytest.raises(InputError) as exc:
        check_recorded_as_scheduled(_schedule(rows), _recorded(), "s.csv")
    msg = str(exc.value)
    assert "\n" not in msg and "s.csv" in msg and "cannot record" in msg
    assert rows[row]["kind"] in msg and f"row {named}:" in msg


def test_a_point_scheduled_more_often_than_recorded_is_refused():
    rows = GOOD + [{"kind": "time_scan", "repeat": 3, "point": 0, "A": 0.6, "dpd": 1,
                    "shots": 300, "t_us": 0.0}]
    with pytest.raises(InputError, match="row 31"):
        check_recorded_as_scheduled(_schedule(rows), _recorded(), "s.csv")
