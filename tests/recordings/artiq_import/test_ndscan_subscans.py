"""ndscan subscans imported as rows: one per inner point, the outer point's values repeated.

The files have the layout ndscan's ``setattr_subscan`` gives a parent scan
(``<scan>_axis_<i>``, ``<scan>_channel_<name>``, ``<scan>_spec``), written by
:mod:`dpdfit.simulation.ndscan_subscan_results`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("h5py")

from dpdfit.errors import InputError  # noqa: E402
from dpdfit.recordings.artiq import read_results_file  # noqa: E402
from dpdfit.recordings.campaign_import import import_campaign  # noqa: E402
from dpdfit.simulation.artiq_results_file import (axis, channel, ndscan_datasets,  # noqa: E402
                                                  write_results_file)
from dpdfit.simulation.ndscan_subscan_results import subscan_channels  # noqa: E402
from tests.helpers.mapping_text import CALIBRATION_STUB  # noqa: E402
from tests.helpers.paths import ROOT  # noqa: E402

BUNDLED = ROOT / "datasets" / "synthetic_campaign"
MAPPING = CALIBRATION_STUB.replace("{", "{{").replace("}", "}}") + '''[[time_scans]]
files = "results/**/*.h5"
subscan = "{subscan}"
[time_scans.columns]
A = {{ argument = "amplitude" }}
dpd = {{ axis = "dpd" }}
t_us = {{ axis = "duration" }}
n00 = {{ channel = "n00" }}
n11 = {{ channel = "n11" }}
n01_10 = {{ channel = "n01_10" }}
shots = {{ expr = "sum([channel('n00'), channel('n01_10'), channel('n11')])" }}
'''


@pytest.fixture()
def time_scan_file(tmp_path):
    """The bundled time scans as one run: dpd the outer axis, duration the subscan's."""
    ts = pd.read_csv(BUNDLED / "time_scans.csv", comment="#").sort_values(["dpd", "t_us"])
    wide = {c: np.stack([g[c].to_numpy() for _, g in ts.groupby("dpd")])
            for c in ("t_us", "n00", "n11", "n01_10")}
    sub = subscan_channels("time", "lab.gate.TimeScan",
                           [axis("duration", wide["t_us"] * 1e-6, "us", 1e-6)],
                           {c: channel(wide[c]) for c in ("n00", "n11", "n01_10")})
    ds = ndscan_datasets(5, "lab.gate.DpdTimeScans", [axis("dpd", np.array([0, 1]))], sub)
    write_results_file(tmp_path, 5, "DpdTimeScans", 1.7e9, ds, arguments={"amplitude": 0.5})
    return tmp_path, ts


def test_a_subscan_maps_to_one_row_per_inner_point(time_scan_file):
    folder, ts = time_scan_file
    path = folder / "map.toml"
    path.write_text(MAPPING.format(subscan="time"))
    got = import_campaign(path).tables["time_scans"]
    assert len(got) == len(ts) == 50
    got = got.sort_values(["dpd", "t_us"]).reset_index(drop=True)
    ts = ts.reset_index(drop=True)
    for c in ("A", "dpd", "n00", "n11", "n01_10", "shots"):
        np.testing.assert_array_equal(got[c].to_numpy(), ts[c].to_numpy(), err_msg=c)
    np.testing.assert_allclose(got["t_us"], ts["t_us"], rtol=1e-15)
    # the outer axis is repeated over each point's inner points, in acquisition order
    assert got["dpd"].tolist() == [0] * 25 + [1] * 25


def test_the_reader_gives_the_subscan_with_its_units(time_scan_file):
    folder, _ = time_scan_file
    rf = read_results_file(next(folder.glob("results/**/*.h5")))
    scan = rf.scan()
    assert list(scan.subscans) == ["time"]
    flat = scan.subscan("time")
    assert flat.n_points == 50 and flat.axis("duration").unit == "us"
    assert flat.axis("duration").scale == 1e-6 and flat.axis("dpd").values.tolist()[:2] == [0, 0]


def test_an_unknown_subscan_lists_the_files_subscans(time_scan_file):
    folder, _ = time_scan_file
    path = folder / "map.toml"
    path.write_text(MAPPING.format(subscan="timing"))
    with pytest.raises(InputError, match=r"no subscan 'timing' \(subscans: time\)"):
        import_campaign(path)


def test_a_subscan_channel_mapped_without_the_subscan_says_so(time_scan_file):
    folder, _ = time_scan_file
    path = folder / "map.toml"
    text = MAPPING.format(subscan="time").replace('subscan = "time"\n', "")
    text = text.replace('axis = "duration"', 'channel = "time_axis_0"')
    path.write_text(text)
    with pytest.raises(InputError, match="belongs to the ndscan subscan 'time': give the "
                                         "source subscan = \"time\""):
        import_campaign(path)


def test_inner_arrays_of_different_lengths_are_refused(tmp_path):
    sub = subscan_channels("time", "lab.T", [axis("duration", np.ones((2, 3)) * 1e-6, "us",
                                                  1e-6)],
                           {"n00": channel(np.ones((2, 3), dtype=int))})
    sub["time_channel_n00"]["values"] = np.ones((2, 4), dtype=int)
    ds = ndscan_datasets(1, "lab.P", [axis("dpd", np.array([0, 1]))], sub)
    write_results_file(tmp_path, 1, "P", 1.7e9, ds, arguments={"amplitude": 0.5})
    path = tmp_path / "map.toml"
    path.write_text(MAPPING.format(subscan="time"))
    with pytest.raises(InputError, match=r"subscan 'time', outer point 1: "
                                         r"'ndscan.rid_1.points.channel_time_channel_n00' has 4 "
                                         r"inner points but '.*time_axis_0' has 3"):
        import_campaign(path)
