"""Bad results files and bad mappings: one line naming file, root and dataset (or the
mapping's key and line), exit status 2, nothing written."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

h5py = pytest.importorskip("h5py")

from dpdfit.cli.main import main  # noqa: E402
from dpdfit.simulation.artiq_results_file import (axis, channel, ndscan_datasets,  # noqa: E402
                                                  write_results_file)

T0 = 1.76e9
MAPPING = '''\
[campaign]
nu_hz = 1.84e6

[[calibration_amplitude]]
files = "results/*/*/*-AmplitudeCalibration.h5"
[calibration_amplitude.columns]
A = { axis = "amplitude" }
power = { channel = "pd_power" }
run = { run = "rid", format = "R{:03d}" }
timestamp = { run = "start_time" }

[[parity]]
files = "results/*/*/*-ParityScan.h5"
[parity.columns]
A = { argument = "amplitude" }
dpd = { argument = "dpd" }
phase_rad = { axis = "phase" }
n_even = { channel = "n_even" }
shots = { channel = "shots" }
'''


def _lab(folder: Path, *, power=None, n_even=None, phase=None, parity_extra=None):
    a = np.linspace(0, 1, 21)
    power = a ** 2 if power is None else power
    write_results_file(folder, 1, "AmplitudeCalibration", T0, ndscan_datasets(
        1, "lab.AmplitudeCalibration", [axis("amplitude", a)],
        {"pd_power": channel(power)}))
    phase = np.linspace(0, 2 * np.pi, 16, endpoint=False) if phase is None else phase
    n_even = np.full(16, 300) if n_even is None else n_even
    ds = ndscan_datasets(2, "lab.ParityScan", [axis("phase", phase, "rad")],
                         {"n_even": channel(n_even), "shots": channel(np.full(16, 400))})
    ds.update(parity_extra or {})
    write_results_file(folder, 2, "ParityScan", T0 + 600, ds,
                       arguments={"amplitude": 0.5, "dpd": 1})


def _not_hdf5(folder):
    _lab(folder)
    p = folder / "results/2025-10-10/10/000000003-ParityScan.h5"
    p.parent.mkdir(parents=True)
    p.write_text("rid,A\n3,0.5\n")
    return MAPPING


def _no_root(folder):
    _lab(folder)
    write_results_file(folder, 3, "ParityScan", T0 + 900, {"counts": np.arange(3)},
                       arguments={"amplitude": 0.5, "dpd": 1})
    return MAPPING


def _length_mismatch(folder):
    _lab(folder, parity_extra={"ndscan.rid_2.points.channel_n_even": np.full(15, 300)})
    return MAPPING


CASES = {
    "not an HDF5 file": (_not_hdf5, ["000000003-ParityScan.h5", "not an HDF5 file"]),
    "no ndscan root": (_no_root, ["000000003-ParityScan.h5", "no ndscan root"]),
    "a glob matching no file": (lambda f: (_lab(f), MAPPING.replace(
        "*-ParityScan.h5", "*-Parity.h5"))[1], ["parity[1].files", "line 13", "no file"]),
    "a missing root": (lambda f: (_lab(f), MAPPING.replace(
        '[[parity]]\n', '[[parity]]\nroot = "ndscan.rid_9."\n'))[1],
        ["000000002-ParityScan.h5", "no ndscan root matches 'ndscan.rid_9.'"]),
    "a missing channel": (lambda f: (_lab(f), MAPPING.replace(
        'channel = "n_even"', 'channel = "n_odd"'))[1],
        ["000000002-ParityScan.h5", "root 'ndscan.rid_2.'", "no channel 'n_odd'",
         "parity[1].columns.n_even", "line 18"]),
    "a missing argument": (lambda f: (_lab(f), MAPPING.replace(
        'argument = "amplitude"', 'argument = "amp"'))[1],
        ["000000002-ParityScan.h5", "no argument 'amp'", "(line 15)"]),
    "an axis and a channel of different lengths": (_length_mismatch, [
        "000000002-ParityScan.h5", "root 'ndscan.rid_2.'", "points.axis_0' has 16 points",
        "points.channel_n_even' has 15"]),
    "a unit that does not convert": (lambda f: (_lab(f), MAPPING.replace(
        'axis = "phase" }', 'axis = "phase", unit = "us" }'))[1],
        ["000000002-ParityScan.h5", "dataset 'ndscan.rid_2.points.axis_0'",
         "unit 'us' does not convert to phase_rad", "line 17"]),
    "a non-finite value": (lambda f: (_lab(f, power=np.r_[np.linspace(0, 1, 20), np.nan]),
                                      MAPPING)[1],
                           ["000000001-AmplitudeCalibration.h5", "points.channel_pd_power'",
                            "point 21 is nan"]),
    "counts above shots": (lambda f: (_lab(f, n_even=np.r_[np.full(15, 300), 401]), MAPPING)[1],
                           ["000000002-ParityScan.h5", "points.channel_n_even'",
                            "point 16: n_even = 401 exceeds shots = 400"]),
    "an unknown column": (lambda f: (_lab(f), MAPPING.replace("n_even =", "n_evn ="))[1],
                          ["parity[1].columns.n_evn", "line 18", "did you mean 'n_even'"]),
    "an unknown table": (lambda f: (_lab(f), MAPPING.replace("[[parity]]", "[[parities]]")
                                    .replace("[parity.columns]", "[parities.columns]"))[1],
                         ["unknown top-level key 'parities'", "(line 12)"]),
    "an unknown column key": (lambda f: (_lab(f), MAPPING.replace(
        'axis = "phase" }', 'axis = "phase", units = "rad" }'))[1],
        ["parity[1].columns.phase_rad.units", "line 17", "did you mean 'unit'"]),
    "a mapping that is not TOML": (lambda f: (_lab(f), MAPPING + "\nthis is = not = toml\n")[1],
                                   ["not valid TOML", "line 21"]),
}


@pytest.mark.parametrize("case", list(CASES))
def test_bad_input_is_one_line_exit_2_nothing_written(case, tmp_path, capsys):
    make, expected = CASES[case]
    lab = tmp_path / "lab"
    lab.mkdir()
    (lab / "map.toml").write_text(make(lab))
    before = sorted(p.relative_to(lab) for p in lab.rglob("*"))
    out = tmp_path / "campaign"
    rc = main(["import", str(lab / "map.toml"), "-o", str(out)])
    err = capsys.readouterr().err
    lines = [x for x in err.splitlines() if x.strip()]
    assert rc == 2, err
    assert len(lines) == 1 and lines[0].startswith("dpdfit: error: "), err
    for fragment in expected:
        assert fragment in lines[0], (fragment, lines[0])
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["lab"]
    assert sorted(p.relative_to(lab) for p in lab.rglob("*")) == before


def test_the_good_lab_imports(tmp_path, capsys):
    lab = tmp_path / "lab"
    lab.mkdir()
    _lab(lab)
    (lab / "map.toml").write_text(MAPPING)
    assert main(["import", str(lab / "map.toml"), "-o", str(tmp_path / "c")]) == 0
    assert (tmp_path / "c" / "parity.csv").read_text().splitlines()[0] == \
        "A,dpd,scan,phase_rad,n_even,shots,source_file,source_rid"


def test_an_existing_campaign_folder_is_never_overwritten(tmp_path, capsys):
    lab = tmp_path / "lab"
    lab.mkdir()
    _lab(lab)
    (lab / "map.toml").write_text(MAPPING)
    out = tmp_path / "c"
    out.mkdir()
    (out / "campaign.json").write_text("{}")
    assert main(["import", str(lab / "map.toml"), "-o", str(out)]) == 2
    assert "never overwrites" in capsys.readouterr().err
    assert [p.name for p in out.iterdir()] == ["campaign.json"]


def test_without_h5py_the_message_names_the_extra(monkeypatch):
    import builtins

    from dpdfit.errors import DpdfitError
    from dpdfit.recordings.hdf5_contents import h5py_module
    real = builtins.__import__

    def no_h5py(name, *a, **kw):
        if name == "h5py":
            raise ImportError(name)
        return real(name, *a, **kw)

    monkeypatch.setattr(builtins, "__import__", no_h5py)
    with pytest.raises(DpdfitError, match=r"pip install 'dpdfit\[artiq\]'"):
        h5py_module()
