"""A schedule holding every characterisation at once: the Ramsey and thermometry rows
share ``wait_us`` (each keeps its own wait), and the extra columns come in one fixed
order, written and read back unchanged."""

from __future__ import annotations

import numpy as np
import pandas as pd

from dpdfit.recordings.schedule import (SCHEDULE_COLUMNS, check_schedule, read_schedule,
                                        write_schedule)


def _mixed() -> pd.DataFrame:
    return pd.DataFrame([
        dict(kind="spam", repeat=1, point=0, A=0.0, shots=10, prepared="00"),
        dict(kind="ramsey", repeat=1, point=0, A=0.0, shots=10, sequence="echo",
             wait_us=5.0),
        dict(kind="detector_linearity", repeat=1, point=0, A=0.5, attenuation_db=10.0),
        dict(kind="thermometry", repeat=1, point=0, A=0.0, shots=10, wait_us=100.0,
             sideband="blue"),
    ])


def test_ramsey_and_thermometry_keep_their_own_waits_in_one_column_order(tmp_path):
    out = check_schedule(_mixed())
    assert list(out.columns) == list(SCHEDULE_COLUMNS) + [
        "prepared", "sequence", "wait_us", "attenuation_db", "sideband"]
    np.testing.assert_array_equal(out["wait_us"].to_numpy(float),
                                  [np.nan, 5.0, np.nan, 100.0])
    assert out["sequence"].tolist() == ["", "echo", "", ""]
    assert out["sideband"].tolist() == ["", "", "", "blue"]
    write_schedule(out, tmp_path / "schedule.csv")
    back = read_schedule(tmp_path / "schedule.csv")
    assert list(back.columns) == list(out.columns)
    np.testing.assert_array_equal(back["wait_us"].to_numpy(float),
                                  out["wait_us"].to_numpy(float))
    assert back["sideband"].fillna("").tolist() == out["sideband"].tolist()
