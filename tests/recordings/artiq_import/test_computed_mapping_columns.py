"""Computed mapping columns (``expr``) and name patterns, round-tripped through results files.

Each test writes results files in a shape labs record (probabilities with the
shots as an argument; counts in two datasets; one channel per tone) with the
bundled campaign's numbers, imports them with a mapping that computes the
column, and compares with the bundled table.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("h5py")

from dpdfit.errors import InputError  # noqa: E402
from dpdfit.recordings.campaign_import import import_campaign  # noqa: E402
from dpdfit.recordings.mapping import read_mapping  # noqa: E402
from dpdfit.simulation.artiq_results_file import (axis, channel, ndscan_datasets,  # noqa: E402
                                                  write_results_file)
from tests.helpers.mapping_text import CALIBRATION_STUB  # noqa: E402
from tests.helpers.paths import ROOT  # noqa: E402

BUNDLED = ROOT / "datasets" / "synthetic_campaign"


def _bundled(table: str) -> pd.DataFrame:
    return pd.read_csv(BUNDLED / f"{table}.csv", comment="#")


def _write_mapping(folder: Path, text: str) -> Path:
    path = folder / "map.toml"
    path.write_text(CALIBRATION_STUB + text)
    return path


def _sorted(df: pd.DataFrame, keys) -> pd.DataFrame:
    return df.sort_values(keys, kind="stable").reset_index(drop=True)


def test_counts_from_probabilities_times_the_shots_argument(tmp_path):
    par = _bundled("parity")
    for rid, ((a, dpd, scan), rows) in enumerate(par.groupby(["A", "dpd", "scan"]), 1):
        shots = int(rows["shots"].iloc[0])
        p = rows["n_even"].to_numpy() / shots                 # the lab stores P(even)
        ds = ndscan_datasets(rid, "lab.Parity", [axis("phase", rows["phase_rad"].to_numpy(), "rad")],
                             {"p_even": channel(p)})
        write_results_file(tmp_path, rid, "Parity", 1.7e9 + rid, ds,
                           arguments={"amplitude": a, "dpd": bool(dpd), "shots": shots})
    got = import_campaign(_write_mapping(tmp_path, (
        '[[parity]]\nfiles = "results/**/*.h5"\n[parity.columns]\n'
        'A = { argument = "amplitude" }\ndpd = { argument = "dpd" }\n'
        'phase_rad = { axis = "phase" }\nshots = { argument = "shots" }\n'
        'n_even = { expr = "channel(\'p_even\') * argument(\'shots\')" }\n'))).tables["parity"]
    keys = ["A", "dpd", "scan", "phase_rad"]
    got, want = _sorted(got, keys), _sorted(par, keys)
    for c in want.columns:
        np.testing.assert_array_equal(got[c].to_numpy(), want[c].to_numpy(), err_msg=c)


def _probability_file(folder: Path, p, shots: int = 10_000) -> Path:
    ds = ndscan_datasets(1, "lab.Parity", [axis("phase", np.linspace(0, 1, len(p)), "rad")],
                         {"p_even": channel(np.asarray(p))})
    write_results_file(folder, 1, "Parity", 1.7e9, ds, arguments={"shots": shots})
    return _write_mapping(folder, (
        '[[parity]]\nfiles = "results/**/*.h5"\n[parity.columns]\nA = 0.5\ndpd = 1\n'
        'phase_rad = { axis = "phase" }\nshots = { argument = "shots" }\n'
        'n_even = { expr = "channel(\'p_even\') * argument(\'shots\')" }\n'))


def test_float32_probabilities_are_integers_within_their_rounding(tmp_path):
    k = np.array([0, 1, 3719, 9999, 10_000])
    mapping = _probability_file(tmp_path, (k / 10_000).astype(np.float32))
    got = import_campaign(mapping).tables["parity"]["n_even"].to_numpy()
    np.testing.assert_array_equal(got, k)


def test_a_probability_that_is_no_count_names_its_row(tmp_path):
    mapping = _probability_file(tmp_path, [0.5, 0.25, 0.3719, 0.12345])   # 1234.5 shots
    with pytest.raises(InputError, match=r"point 4: n_even = 1234\.5 must be an integer "
                                         r"\(not within rounding") as exc:
        import_campaign(mapping)
    assert "parity[1].columns.n_even" in str(exc.value) and "\n" not in str(exc.value)


def test_shots_as_the_sum_of_count_datasets(tmp_path):
    ts = _bundled("time_scans")
    for rid, ((a, dpd), rows) in enumerate(ts.groupby(["A", "dpd"]), 1):
        ds = {"times": rows["t_us"].to_numpy() * 1e-6, "n00": rows["n00"].to_numpy(),
              "n11": rows["n11"].to_numpy(), "n01_10": rows["n01_10"].to_numpy()}
        write_results_file(tmp_path, rid, "TimeScan", 1.7e9 + rid, ds,
                           arguments={"amplitude": a, "dpd": int(dpd)},
                           metadata={"times": {"unit": "us"}})      # ARTIQ: stored in s
    got = import_campaign(_write_mapping(tmp_path, (
        '[[time_scans]]\nfiles = "results/**/*.h5"\n[time_scans.columns]\n'
        'A = { argument = "amplitude" }\ndpd = { argument = "dpd" }\n'
        't_us = { dataset = "times" }\nn00 = { dataset = "n00" }\n'
        'n11 = { dataset = "n11" }\nn01_10 = { dataset = "n01_10" }\n'
        'shots = { expr = "sum([dataset(\'n00\'), dataset(\'n01_10\'), dataset(\'n11\')])" }\n'
    ))).tables["time_scans"]
    got, want = _sorted(got, ["A", "dpd", "t_us"]), _sorted(ts, ["A", "dpd", "t_us"])
    for c in ("A", "dpd", "n00", "n11", "n01_10", "shots"):
        np.testing.assert_array_equal(got[c].to_numpy(), want[c].to_numpy(), err_msg=c)
    np.testing.assert_allclose(got["t_us"], want["t_us"], rtol=1e-15)


def test_one_pattern_maps_one_channel_per_tone(tmp_path):
    sp = _bundled("spectra")
    for rid, (dpd, rows) in enumerate(sp.groupby("dpd"), 1):
        wide = rows.pivot(index="A", columns=["sideband", "n"])
        ch = {}
        for (col, name) in (("P_dB", "P"), ("snr_db", "snr"), ("valid", "ok")):
            for sb, n in wide[col].columns:
                ch[f"{name}_{sb}_{n}"] = channel(wide[col][(sb, n)].to_numpy(), "")
        ds = ndscan_datasets(rid, "lab.Spectrum", [axis("amplitude", wide.index.to_numpy())], ch)
        write_results_file(tmp_path, rid, "Spectrum", 1.7e9 + rid, ds,
                           arguments={"dpd": int(dpd)})
    mapping = _write_mapping(tmp_path, (
        '[[spectra]]\nfiles = "results/**/*.h5"\n[spectra.columns]\n'
        'A = { axis = "amplitude" }\ndpd = { argument = "dpd" }\n'
        'P_dB = { channel = "P_{sideband}_{n}" }\nsnr_db = { channel = "snr_{sideband}_{n}" }\n'
        'valid = { channel = "ok_{sideband}_{n}" }\n'))
    assert mapping.read_text().count("[[spectra]]") == 1
    got = import_campaign(mapping).tables["spectra"]
    keys = ["A", "dpd", "sideband", "n"]
    got, want = _sorted(got, keys), _sorted(sp, keys)
    for c in want.columns:
        np.testing.assert_array_equal(got[c].to_numpy(), want[c].to_numpy(), err_msg=c)


@pytest.mark.parametrize("column,why", [
    ('n_even = { expr = "__import__(\'os\').getcwd()" }', "is not allowed"),
    ('n_even = { expr = "channel(\'p\').real" }', "is not allowed"),
    ('n_even = { expr = "channel(\'p\') * " }', "is not an expression"),
    ('n_even = { channel = "n_{colour}" }', "unknown placeholder (a column of parity) 'colour'"),
    ('n_even = { channel = "n_{scan}" }\nphase_rad = { channel = "x" }\n'
     'scan = 1', "placeholder '{scan}' names the column scan"),
])
def test_a_bad_computed_column_is_refused_with_its_key_and_line(tmp_path, column, why):
    text = ('[[parity]]\nfiles = "results/**/*.h5"\n[parity.columns]\nA = 0.5\ndpd = 1\n'
            'shots = 100\n' + ("" if "phase_rad" in column else 'phase_rad = 0.0\n') + column)
    with pytest.raises(InputError, match="line") as exc:
        read_mapping(_write_mapping(tmp_path, text))
    assert why in str(exc.value) and "\n" not in str(exc.value)


def test_a_pattern_that_matches_no_channel_says_what_the_file_has(tmp_path):
    ds = ndscan_datasets(1, "lab.Spectrum", [axis("amplitude", np.array([0.1, 0.2]))],
                         {"power_red_1": channel(np.array([-30.0, -29.0]))})
    write_results_file(tmp_path, 1, "Spectrum", 1.7e9, ds)
    mapping = _write_mapping(tmp_path, (
        '[[spectra]]\nfiles = "results/**/*.h5"\n[spectra.columns]\n'
        'A = { axis = "amplitude" }\ndpd = 0\nP_dB = { channel = "P_{sideband}_{n}" }\n'))
    with pytest.raises(InputError, match=r"no channel matches the pattern 'P_\{sideband\}_\{n\}'"
                                         r" \(the file has: power_red_1\)"):
        import_campaign(mapping)


def test_a_column_of_a_per_point_table_dataset(tmp_path):
    """One dataset holding a row per point (counts of 00, 01/10 and 11 side by side)."""
    ts = _bundled("time_scans").query("dpd == 1")
    table = ts[["n00", "n01_10", "n11"]].to_numpy()
    write_results_file(tmp_path, 1, "TimeScan", 1.7e9, {"table": table,
                                                        "t": ts["t_us"].to_numpy() * 1e-6},
                       arguments={"amplitude": 0.5})
    mapping = _write_mapping(tmp_path, (
        '[[time_scans]]\nfiles = "results/**/*.h5"\n[time_scans.columns]\n'
        'A = { argument = "amplitude" }\ndpd = 1\nt_us = { dataset = "t", unit = "s" }\n'
        'n00 = { expr = "dataset(\'table\')[:, 0]" }\n'
        'n01_10 = { expr = "dataset(\'table\')[:, 1]" }\n'
        'n11 = { expr = "dataset(\'table\')[:, -1]" }\n'
        'shots = { expr = "sum([dataset(\'table\')[:, 0], dataset(\'table\')[:, 1], '
        'dataset(\'table\')[:, 2]])" }\n'))
    got = import_campaign(mapping).tables["time_scans"]
    for c in ("n00", "n01_10", "n11", "shots"):
        np.testing.assert_array_equal(got[c].to_numpy(), ts[c].to_numpy(), err_msg=c)
    mapping.write_text(mapping.read_text().replace("[:, -1]", "[:, 3]"))
    with pytest.raises(InputError, match=r"dataset\('table'\)\[:, 3\]: the values have shape "
                                         r"\(25, 3\), no column 3"):
        import_campaign(mapping)
