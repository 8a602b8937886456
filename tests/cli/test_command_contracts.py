"""The command line: contracts (names, keys, files) and bad-input behaviour."""

import hashlib
import json

import numpy as np
import pytest

from dpdfit.cli.main import main
from dpdfit.fits.calibration import load_calibration
from dpdfit.models.transfer import TransferFunction
from tests.helpers.cli_refusal import assert_refused
from tests.helpers.cli_run import run
from tests.helpers.paths import ROOT

CONTRACT_KEYS = ["A_corr", "A_corr_stderr", "phi_at_1", "phi_at_1_stderr"]
AMP_KEYS = ["powers", "coefficients", "stderr", "covariance", "monotone"]
PHASE_KEYS = ["powers", "coefficients", "stderr", "covariance"]


def test_calibrate_writes_contract_json_and_plots(bundled_calibration_files, tmp_path, capsys):
    amp, ph = bundled_calibration_files
    out = tmp_path / "calibration.json"
    code, stdout, err = run(["calibrate", "--amplitude", amp, "--phase", ph, "-o", out,
                             "--plot", tmp_path / "figs"], capsys)
    assert code == 0, err
    d = json.loads(out.read_text())
    for k in CONTRACT_KEYS:
        assert isinstance(d[k], float)
    for k in AMP_KEYS:
        assert k in d["amplitude"]
    for k in PHASE_KEYS:
        assert k in d["phase"]
    assert d["amplitude"]["powers"] == list(range(1, 9))
    assert d["phase"]["powers"] == list(range(1, 6))
    assert d["amplitude"]["coefficients"][0] == 1.0
    assert d["A_corr"] == pytest.approx(sum(d["amplitude"]["coefficients"]), rel=1e-12)
    assert np.array(d["amplitude"]["covariance"]).shape == (8, 8)
    assert d["amplitude"]["source"]["sha256"] == hashlib.sha256(amp.read_bytes()).hexdigest()
    for name in ["fig1a_amplitude.png", "fig1b_phase.png", "fig1c_predistortion.png",
                 "fig1_calibration.png"]:
        png = tmp_path / "figs" / name
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "A_corr=y(1)" in stdout and "order scan" in stdout
    # JSON round trip into the API
    cal = load_calibration(out)
    assert cal.A_corr == d["A_corr"]


def test_calibrate_recovers_truth_of_bundled_data(bundled_calibration_files, tmp_path, capsys,
                                                   data_dir):
    amp, ph = bundled_calibration_files
    out = tmp_path / "c.json"
    assert run(["calibrate", "--amplitude", amp, "--phase", ph, "-o", out], capsys)[0] == 0
    d = json.loads(out.read_text())
    truth = json.loads((data_dir / "truth.json").read_text())
    assert abs(d["A_corr"] - truth["A_corr_true"]) < 3 * d["A_corr_stderr"]
    assert abs(d["phi_at_1"] - truth["phi_at_1_true"]) < 3 * d["phi_at_1_stderr"]


def test_lut_csv_npy_json(bundled_calibration_files, tmp_path, capsys):
    amp, ph = bundled_calibration_files
    cal = tmp_path / "calibration.json"
    assert run(["calibrate", "--amplitude", amp, "--phase", ph, "-o", cal], capsys)[0] == 0
    code, out, err = run(["lut", cal, "--points", 257, "-o", tmp_path / "lut.csv"], capsys)
    assert code == 0, err
    import pandas as pd
    df = pd.read_csv(tmp_path / "lut.csv", comment="#")
    assert list(df.columns) == ["target_amplitude", "rf_amplitude", "clamped"]
    assert len(df) == 257
    arr = np.load(tmp_path / "lut.npy")
    assert arr.shape == (257, 2)
    assert np.array_equal(arr[:, 0], df["target_amplitude"].to_numpy())
    assert np.array_equal(arr[:, 1], df["rf_amplitude"].to_numpy())
    prov = json.loads((tmp_path / "lut.json").read_text())
    d = json.loads(cal.read_text())
    assert prov["A_corr"] == d["A_corr"] and prov["order"] == 8
    assert prov["calibration_sha256"] == hashlib.sha256(cal.read_bytes()).hexdigest()
    assert prov["amplitude_input_sha256"] == hashlib.sha256(amp.read_bytes()).hexdigest()
    assert "created" in prov
    header = [l for l in (tmp_path / "lut.csv").read_text().splitlines() if l.startswith("#")]
    assert any(l.startswith("# calibration_sha256:") for l in header)
    tf = TransferFunction.from_calibration(load_calibration(cal))
    inside = ~df["clamped"].astype(bool).to_numpy()
    assert np.max(np.abs(tf.f_am(arr[inside, 1]) - arr[inside, 0])) <= 1e-12
    assert np.all(arr[~inside, 1] == 1.0)


def test_polyfit_cli_json_keys(tmp_path, capsys):
    x = np.linspace(-1, 1, 30)
    y = 1 + 2 * x - 0.5 * x ** 3
    p = tmp_path / "d.csv"
    p.write_text("t,v,s\n" + "".join(f"{float(a)!r},{float(b)!r},0.1\n" for a, b in zip(x, y)))
    code, out, err = run(["polyfit", p, "--x", "t", "--y", "v", "--powers", "0:3",
                          "--sigma", "s", "--json"], capsys)
    assert code == 0, err
    d = json.loads(out)
    for k in ["coefficients", "stderr", "covariance", "residual_std", "r2", "aic", "bic",
              "condition_number"]:
        assert k in d
    assert np.allclose(d["coefficients"], [1, 2, 0, -0.5], atol=1e-12)
    code, out, err = run(["polyfit", p, "--x", "t", "--y", "v", "--powers", "1,3"], capsys)
    assert code == 0 and "coefficient" in out.lower() and "[[Covariance]]" in out


# ----------------------------------------------------------------- bad input

def _amp_text(rows):
    return "A,power\n" + "".join(f"{a},{p}\n" for a, p in rows)


GOOD = [(a, (np.sin(np.pi / 2 * a) * 1.3) ** 2) for a in np.linspace(0, 1, 21)]


@pytest.mark.parametrize("text, needle", [
    ("A,pwr\n0.1,1\n", "column 'power': required column is missing (found 'pwr'"),
    (_amp_text(GOOD[:5] + [(0.5, "nan")] + GOOD[6:]), "column 'power', row 6: value is NaN"),
    (_amp_text(GOOD[:5] + [(0.5, "inf")] + GOOD[6:]), "column 'power', row 6: value is inf"),
    (_amp_text(GOOD[:3] + [(1.5, 0.3)] + GOOD[4:]), "column 'A', row 4: value 1.5 is outside [0, 1]"),
    (_amp_text(GOOD[:5]), "needs at least 8 distinct amplitudes"),
    ("", "file is empty"),
    ("A,power\n", "no data rows"),
    ("A,power,power_err\n" + "".join(f"{a},{p},0.001\n" for a, p in GOOD)
     + "0.5,9.0,0.001\n", "duplicate A=0.5 with contradicting values"),
])
def test_calibrate_bad_input(tmp_path, capsys, text, needle):
    p = tmp_path / "amp.csv"
    p.write_text(text)
    line = assert_refused(capsys, ["calibrate", "--amplitude", p, "-o", tmp_path / "cal.json"],
                          [needle], [p], no_partial_output_in=tmp_path)
    assert "amp.csv" in line


def test_consistent_duplicates_are_accepted(tmp_path, capsys):
    rows = GOOD + [(0.5, GOOD[10][1] + 1e-4)]
    p = tmp_path / "amp.csv"
    p.write_text("A,power,power_err\n" + "".join(f"{a},{v},0.001\n" for a, v in rows))
    code, out, err = run(["calibrate", "--amplitude", p, "-o", tmp_path / "c.json"], capsys)
    assert code == 0, err


def test_refuses_to_overwrite_input(bundled_calibration_files, tmp_path, capsys):
    amp, ph = bundled_calibration_files
    assert_refused(capsys, ["calibrate", "--amplitude", amp, "-o", amp], ["refusing to overwrite"],
                   [amp], no_partial_output_in=tmp_path)


def test_lut_not_invertible(tmp_path, capsys):
    cal = {"amplitude": {"powers": [1, 2, 3], "coefficients": [1.0, -2.0, 1.25],
                         "stderr": [0, 0, 0], "covariance": [[0] * 3] * 3, "monotone": False}}
    p = tmp_path / "bad_cal.jsn"
    p.write_text(json.dumps(cal))
    assert_refused(capsys, ["lut", p, "--points", 11, "-o", tmp_path / "lut.csv"],
                   ["dy/dA <= 0 at A = 0.400000"], [p], no_partial_output_in=tmp_path)
    assert not (tmp_path / "lut.csv").exists()


def test_lut_bad_calibration_file(tmp_path, capsys):
    p = tmp_path / "x.txt"
    p.write_text("{not json")
    assert_refused(capsys, ["lut", p, "-o", tmp_path / "lut.csv"], ["not valid JSON"], [p],
                   no_partial_output_in=tmp_path)


def test_polyfit_bad_powers_and_columns(tmp_path, capsys):
    p = tmp_path / "d.csv"
    p.write_text("x,y\n1,2\n2,3\n3,5\n")
    assert_refused(capsys, ["polyfit", p, "--x", "x", "--y", "y", "--powers", "a:b"],
                   ["bad power range"], [p], no_partial_output_in=tmp_path)
    assert_refused(capsys, ["polyfit", p, "--x", "x", "--y", "yy", "--powers", "0:1"],
                   ["column 'yy': required column is missing"], [p], no_partial_output_in=tmp_path)
    assert_refused(capsys, ["polyfit", p, "--x", "x", "--y", "y", "--powers", "0:5"],
                   ["3 points for 6 coefficients"], [p], no_partial_output_in=tmp_path)


def test_multi_run_file_needs_run(tmp_path, capsys, data_dir):
    src = (data_dir / "calibration_amplitude.csv").read_text().splitlines()
    header = [l for l in src if not l.startswith("#")][0]
    body = [l for l in src if not l.startswith("#")][1:]
    two = [header] + body + [l.replace("R001", "R002") for l in body]
    p = tmp_path / "runs.csv"
    p.write_text("\n".join(two) + "\n")
    assert_refused(capsys, ["calibrate", "--amplitude", p, "-o", tmp_path / "c.json"],
                   ["holds 2 runs (R001, R002)"], [p], no_partial_output_in=tmp_path)
    code, out, err = run(["calibrate", "--amplitude", p, "--run", "R002", "-o",
                          tmp_path / "c.json", "--order-scan", "none"], capsys)
    assert code == 0, err
    assert json.loads((tmp_path / "c.json").read_text())["amplitude"]["source"]["run"] == "R002"
    code, out, err = run(["calibrate", "--amplitude", p, "--all-runs", "-o",
                          tmp_path / "runs.json"], capsys)
    assert code == 0, err
    d = json.loads((tmp_path / "runs.json").read_text())
    assert [r["run"] for r in d["amplitude_runs"]] == ["R001", "R002"]


def test_phase_file_bad_input_names_phase_file(bundled_calibration_files, tmp_path, capsys):
    amp, ph = bundled_calibration_files
    lines = ph.read_text().splitlines()
    data_start = next(i for i, l in enumerate(lines) if l.startswith("run,"))
    cells = lines[data_start + 7].split(",")
    cells[3] = "nan"                       # phase_rad of data row 7
    lines[data_start + 7] = ",".join(cells)
    ph.write_text("\n".join(lines) + "\n")
    line = assert_refused(capsys, ["calibrate", "--amplitude", amp, "--phase", ph, "-o",
                                   tmp_path / "c.json"],
                          ["column 'phase_rad', row 7: value is NaN"], [amp, ph],
                          no_partial_output_in=tmp_path)
    assert "phase.csv" in line


def test_zero_dof_calibration_round_trips(tmp_path, capsys):
    """n == K points with given errors: dof = 0, reduced chi2 undefined -> JSON null."""
    A = np.linspace(0.1, 1, 8)
    P = (np.sin(np.pi / 2 * A) * 1.3) ** 2
    p = tmp_path / "amp.csv"
    p.write_text("A,power,power_err\n" + "".join(f"{a},{v},0.001\n" for a, v in zip(A, P)))
    out = tmp_path / "c.json"
    code, _, err = run(["calibrate", "--amplitude", p, "-o", out, "--order-scan", "none"], capsys)
    assert code == 0, err
    d = json.loads(out.read_text())
    assert d["amplitude"]["dof"] == 0 and d["amplitude"]["reduced_chi2"] is None
    assert load_calibration(out).amplitude.dof == 0
    code, _, err = run(["lut", out, "--points", 5, "-o", tmp_path / "lut.csv"], capsys)
    assert code == 0, err


def test_ctrl_c_exits_130_with_one_line_and_leaves_outputs(tmp_path, capsys, monkeypatch):
    """Ctrl-C during a command: one line, exit 130, no traceback, the output untouched."""
    import dpdfit.fits.calibration as fits_calibration
    out = tmp_path / "c.json"
    out.write_text("previous")

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    # the command imports the fit when it runs: replaced in its package
    monkeypatch.setattr(fits_calibration, "calibrate_amplitude", interrupted)
    amp = ROOT / "datasets" / "synthetic_aom" / "calibration_amplitude.csv"
    code = main(["calibrate", "--amplitude", str(amp), "-o", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 130
    assert err == ["dpdfit: interrupted"]
    assert out.read_text() == "previous"
