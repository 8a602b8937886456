"""Results files as real labs wrote them: one real ARTIQ 8 file (MIT, committed with its
licence) and the layouts of real files whose licence does not allow copying them.

The survey behind these (14,933 public results files from 11 repositories) is
summarised in the import guide's section "Real results files".
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

h5py = pytest.importorskip("h5py")

from dpdfit.errors import InputError  # noqa: E402
from dpdfit.recordings.artiq import read_results_file  # noqa: E402
from dpdfit.recordings.campaign_import import import_campaign  # noqa: E402
from dpdfit.recordings.units import scale_from_metadata, stored_unit  # noqa: E402
from tests.helpers.mapping_text import CALIBRATION_STUB  # noqa: E402
from tests.helpers.paths import TEST_DATA  # noqa: E402

REAL = TEST_DATA / "real_artiq_results" / "haeffnerlab_photonics"
PHOTONICS = REAL / "000071085-track_sideband_with_seq.h5"
SHOTS = "Check_729_Freq_cal_num_samples_per_freq"


def test_the_real_artiq_8_file_is_read_with_its_provenance():
    rf = read_results_file(PHOTONICS)
    assert rf.run.rid == 71085 and rf.run.artiq_version.startswith("8.")
    assert rf.run.sha256 == hashlib.sha256(PHOTONICS.read_bytes()).hexdigest()
    assert rf.run.arguments[SHOTS] == 25 and rf.scans == {}
    assert rf.datasets["cal_count"][0].shape == (25,)


def test_keys_with_a_slash_are_read_and_follow_artiqs_unit_rule():
    raw, attrs = read_results_file(PHOTONICS).datasets["__param__VdP2mode/vib_freq2"]
    assert attrs == {"unit": "MHz"}                       # ARTIQ 8: a unit, no scale
    assert stored_unit(attrs["unit"], scale_from_metadata(attrs)) == "Hz"
    assert 0.1 < float(raw) / 1e6 < 10                    # a mode frequency in MHz


@pytest.mark.parametrize("expr", [f"dataset('cal_count') * argument('{SHOTS}')",
                                  f"round(dataset('cal_count') * argument('{SHOTS}'))"])
def test_probabilities_times_the_shots_argument_import_as_counts(tmp_path, expr):
    mapping = tmp_path / "map.toml"
    mapping.write_text(f'''
[[calibration_amplitude]]
files = "{REAL.as_posix()}/*.h5"
[calibration_amplitude.columns]
A = {{ argument = "Check_729_Freq_cal_amp_729_sp" }}
power = {{ dataset = "cal_fit_signal" }}

[[populations]]
files = "{REAL.as_posix()}/*.h5"
[populations.columns]
A = {{ argument = "Check_729_Freq_cal_amp_729_sp" }}
dpd = 0
shots = {{ argument = "{SHOTS}" }}
n_even = {{ expr = "{expr}" }}
''')
    imp = import_campaign(mapping)
    pop = imp.tables["populations"]
    p = read_results_file(PHOTONICS).datasets["cal_count"][0]
    assert len(pop) == 25 and (pop["shots"] == 25).all()
    np.testing.assert_array_equal(pop["n_even"].to_numpy(), np.round(p * 25).astype(int))
    assert imp.meta["imported"]["sources"][0]["rid"] == 71085
    imp.write(tmp_path / "campaign")          # the campaign folder's readers accept it


def _artiq5_file(path: Path, datasets: dict, arguments: dict, rid: int = 6382) -> Path:
    """An ARTIQ 5 results file as its worker wrote it: no unit attributes, JSON expid,
    int32 rid (a Windows master), bytes version."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with h5py.File(path, "w") as f:
        g = f.create_group("datasets")
        for k, v in datasets.items():
            g[k] = v
        f.create_group("archive")
        f["artiq_version"] = b"5.6915.c9356aba.beta"
        f["rid"] = np.int32(rid)
        f["start_time"] = 1569947980.0
        f["run_time"] = 1569948100.0
        f["expid"] = json.dumps({"log_level": 30, "file": "repository/raman.py",
                                 "class_name": "Ba_Raman", "arguments": arguments})
    return path


def _raman_layout(folder: Path, amplitude_argument: dict) -> Path:
    """The layout of MonroeQuantumNetworks/artiq-experiments rid 6382 (no licence, so
    not copied): per-point int32 sums, the scanned time in seconds, a 2-D ratio list,
    byte-string name lists, the amplitude a Scannable argument held fixed."""
    n = 36
    rng = np.random.default_rng(6382)
    sum11 = rng.integers(1, 13, n).astype(np.int32)
    sum12 = rng.integers(60, 111, n).astype(np.int32)
    scan_x = np.arange(n) * 2.004e-08
    ratio = np.column_stack([sum11, sum12, sum11 / (sum11 + sum12), sum12 / (sum11 + sum12)])
    _artiq5_file(folder / "results/2019-10-01/12/000006382-Ba_Raman.h5",
                 {"sum11": sum11, "sum12": sum12, "scan_x": scan_x, "ratio_list": ratio,
                  "active_scan_names": np.array([b"raman_time"]),
                  "Ba_detection_names": np.array([b"sum11", b"sum12", b"detect11"])},
                 {"detections_per_point": 10000, "amplitude__scan": amplitude_argument,
                  "raman_time__scan": {"ty": "RangeScan", "start": 0.0, "stop": 1e-05,
                                       "npoints": 500, "randomize": False, "seed": None}})
    mapping = folder / "map.toml"
    mapping.write_text('''
[[calibration_amplitude]]
files = "results/**/*.h5"
[calibration_amplitude.columns]
A = { argument = "amplitude__scan" }
power = { dataset = "sum12" }

[[time_scans]]
files = "results/**/*.h5"
[time_scans.columns]
A = { argument = "amplitude__scan" }
dpd = 0
t_us = { dataset = "scan_x", unit = "s" }
n00 = { dataset = "sum11" }
n11 = { dataset = "sum12" }
shots = { expr = "dataset('sum11') + dataset('sum12')" }
''')
    return mapping


def test_an_artiq_5_scan_with_a_computed_shots_column(tmp_path):
    mapping = _raman_layout(tmp_path, {"ty": "NoScan", "value": 0.96, "repetitions": 1})
    ts = import_campaign(mapping).tables["time_scans"]
    assert len(ts) == 36 and (ts["A"] == 0.96).all() and (ts["source_rid"] == 6382).all()
    assert (ts["shots"] == ts["n00"] + ts["n11"]).all()
    np.testing.assert_allclose(ts["t_us"], np.arange(36) * 2.004e-2, rtol=1e-12)


def test_a_scanned_argument_is_refused_in_one_line(tmp_path):
    mapping = _raman_layout(tmp_path, {"ty": "RangeScan", "start": 0.5, "stop": 1.0,
                                       "npoints": 6})
    with pytest.raises(InputError, match="argument 'amplitude__scan' is a RangeScan "
                                         r"\(scanned\): its values are in the run's datasets"):
        import_campaign(mapping)


def test_shots_never_taken_in_a_nan_prefilled_array_are_not_counted(tmp_path):
    """The layout of CampbellGroup/Yaax Rabi_Flopping (MIT): a (points, shots) array
    pre-filled with NaN, of which an interrupted run filled the first points."""
    counts = np.full((10, 100), np.nan)
    counts[:3] = np.random.default_rng(1).integers(0, 2, (3, 100))
    counts[2, 60:] = np.nan                                 # the last point half taken
    _artiq5_file(tmp_path / "results/2023-09-12/09/000001374-Rabi_Flopping.h5",
                 {"Rabi_Exp_Counts": counts, "t": np.arange(10) * 1e-6}, {}, rid=1374)
    mapping = tmp_path / "map.toml"
    mapping.write_text(CALIBRATION_STUB + '''
[[time_scans]]
files = "results/**/*.h5"
[time_scans.columns]
A = 0.5
dpd = 0
t_us = { dataset = "t", unit = "s" }
n00 = { dataset = "Rabi_Exp_Counts", count = 0 }
n11 = { dataset = "Rabi_Exp_Counts", count = 1 }
shots = { dataset = "Rabi_Exp_Counts", count = "all" }
''')
    imp = import_campaign(mapping)
    ts = imp.tables["time_scans"]
    assert ts["shots"].tolist() == [100, 100, 60]
    assert (ts["n00"] + ts["n11"] == ts["shots"]).all()
    assert any("7 of 10 points of 'Rabi_Exp_Counts' hold no outcome" in w
               for w in imp.warnings)


def test_an_aborted_run_in_a_months_glob_can_be_skipped_with_a_warning(tmp_path):
    mapping = _raman_layout(tmp_path, {"ty": "NoScan", "value": 0.96})
    # a run stopped before its first point: the scanned value never archived
    _artiq5_file(tmp_path / "results/2019-10-01/13/000006390-Ba_Raman.h5",
                 {"sum11": np.zeros(0, np.int32), "sum12": np.zeros(0, np.int32)},
                 {"amplitude__scan": {"ty": "NoScan", "value": 0.96}}, rid=6390)
    with pytest.raises(InputError, match="000006390-Ba_Raman.h5: no dataset 'scan_x'"):
        import_campaign(mapping)
    imp = import_campaign(mapping, skip_bad_files=True)
    assert len(imp.tables["time_scans"]) == 36
    assert sum("000006390-Ba_Raman.h5" in w and "skipped" in w for w in imp.warnings) == 1


def test_skipping_never_hides_a_mapping_that_reads_no_file(tmp_path):
    mapping = _raman_layout(tmp_path, {"ty": "NoScan", "value": 0.96})
    mapping.write_text(mapping.read_text().replace('dataset = "scan_x"', 'dataset = "scan_y"'))
    with pytest.raises(InputError, match="no dataset 'scan_y'"):
        import_campaign(mapping, skip_bad_files=True)


def test_a_plain_scan_shorter_than_its_scan_argument_planned_is_warned(tmp_path):
    mapping = _raman_layout(tmp_path, {"ty": "NoScan", "value": 0.96})
    imp = import_campaign(mapping)                  # 36 points of a 500-point RangeScan
    assert len(imp.tables["time_scans"]) == 36
    assert any("36 points recorded of the 500 its scan argument 'raman_time__scan' planned"
               in w for w in imp.warnings)
