"""Bad input: one line 'dpdfit: error: ...', exit status 2, inputs untouched.

NaN calibration coefficients, a sweep grid too large to allocate, NaN and
out-of-range numeric options, duplicated or out-of-range rows of sweep, gate
and gate-rate tables, time-scan counts above the shots in ``diagnose``.
"""

import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from dpdfit.analyses.sweep import MAX_SWEEP_SAMPLES, SweepConfig, check_sweep_size
from dpdfit.cli.main import main
from tests.helpers.cli_refusal import assert_refused
from dpdfit.errors import InputError
from dpdfit.fits.calibration import load_calibration
from tests.helpers.paths import ROOT

AMP = ROOT / "datasets" / "synthetic_aom" / "calibration_amplitude.csv"
CAMP = ROOT / "datasets" / "synthetic_campaign"


# ----------------------------------------------------------------------------- calibration


@pytest.mark.parametrize("key", ["coefficients", "covariance"])
def test_nan_in_calibration_json_is_named_by_file_and_key(cli_outputs, tmp_path, capsys, key):
    d = json.loads(cli_outputs["cal"].read_text())
    if key == "coefficients":
        d["amplitude"][key][3] = float("nan")
    else:
        d["amplitude"][key][2][2] = float("nan")
    p = tmp_path / "nan_cal.json"
    p.write_text(json.dumps(d))
    for argv in (["lut", p, "-o", tmp_path / "lut.csv"], ["sweep", p, "-o", tmp_path / "s.csv"]):
        assert_refused(capsys, argv, [str(p), f"key 'amplitude.{key}'", "finite"], [p])
    assert not (tmp_path / "lut.csv").exists() and not (tmp_path / "s.csv").exists()
    with pytest.raises(InputError) as exc:
        load_calibration(p)
    assert exc.value.file == str(p)


def test_calibration_coefficients_of_the_wrong_length(cli_outputs, tmp_path, capsys):
    d = json.loads(cli_outputs["cal"].read_text())
    d["amplitude"]["coefficients"] = d["amplitude"]["coefficients"][:-1]
    p = tmp_path / "short_cal.json"
    p.write_text(json.dumps(d))
    assert_refused(capsys, ["lut", p, "-o", tmp_path / "lut.csv"],
         [str(p), "key 'amplitude.coefficients'", "shape"], [p])


# ----------------------------------------------------------------------------- sweep size


def test_sweep_refuses_a_sample_grid_too_large(cli_outputs, tmp_path, capsys):
    out = tmp_path / "s.csv"
    line = assert_refused(capsys, ["sweep", cli_outputs["cal"], "--nu", "1e12", "-o", out],
                ["option --nu", "--xi0", "samples", "limit"], [cli_outputs["cal"]])
    assert "9.0" in line or "900169200" in line
    assert not out.exists()
    with pytest.raises(InputError, match="MAX_SWEEP_SAMPLES"):
        check_sweep_size(SweepConfig(nu=1e12))
    assert check_sweep_size(SweepConfig()).n_samples * 101 < MAX_SWEEP_SAMPLES


# ----------------------------------------------------------------------------- options


def _option_cases(cli_outputs, tmp):
    cal, sweep, gate = cli_outputs["cal"], cli_outputs["sweep"], cli_outputs["gate"]
    runs = CAMP / "calibration_amplitude.csv"
    return [
        (["sweep", cal, "--nbar", "nan", "-o", tmp / "x.csv"], "--nbar"),
        (["sweep", cal, "--nbar", "-1", "-o", tmp / "x.csv"], "--nbar"),
        (["sweep", cal, "--xi0", "inf", "-o", tmp / "x.csv"], "--xi0"),
        (["sweep", cal, "--eta-ref", "1.5", "-o", tmp / "x.csv"], "--eta-ref"),
        (["estimate", "--powers-db", "0:-40,1:0,2:0,3:-30", "--nbar", "nan"], "--nbar"),
        (["propagate", "--calibration-runs", runs, "--A", "0.5", "--stale-days", "nan"],
         "--stale-days"),
        (["propagate", "--calibration-runs", runs, "--A", "0.5", "--draws", "0"], "--draws"),
        (["propagate", "--calibration-runs", runs, "--A", "1.5"], "--A"),
        (["im-table", "--nbar", "nan"], "--nbar"),
        (["align", "--gate", gate, "--sweep", sweep, "--sigma-db", "nan"], "--sigma-db"),
        (["align", "--gate", gate, "--sweep", sweep, "--sigma-db", "0"], "--sigma-db"),
        (["thresholds", sweep, "--A-corr", "2"], "--A-corr"),
        (["thresholds", sweep, "--A-corr", "nan"], "--A-corr"),
        (["lut", cal, "--points", "many", "-o", tmp / "l.csv"], "--points"),
        (["calibrate", "--amplitude", AMP, "--order", "0"], "--order"),
        (["budget", "--delta-err", "nan"], "--delta-err"),
        (["diagnose", CAMP, "--pairs", "-1"], "--pairs"),
    ]


@pytest.mark.parametrize("case", range(17))
def test_bad_numeric_option_is_one_line_naming_it(cli_outputs, tmp_path, capsys, case):
    argv, opt = _option_cases(cli_outputs, tmp_path)[case]
    inputs = [a for a in argv if isinstance(a, Path) and a.is_file()]
    assert_refused(capsys, argv, [f"option {opt}:"], inputs)
    assert list(tmp_path.iterdir()) == []


def test_help_and_good_options_still_work(cli_outputs, capsys):
    assert main(["im-table", "--nbar", "0"]) == 0
    assert main(["thresholds", str(cli_outputs["sweep"]), "--A-corr", "1"]) == 0
    assert main(["estimate", "--powers-db", "0:-40,1:0,2:0,3:-30", "--nbar", "0.1"]) == 0
    assert main(["im-table", "--help"]) == 0
    capsys.readouterr()


# ----------------------------------------------------------------------------- sweep table


def _edit_csv(src, dst, edit):
    """Copy ``src`` to ``dst`` keeping its '#' header, with ``edit(df)`` applied."""
    text = Path(src).read_text().splitlines(True)
    header = "".join(line for line in text if line.startswith("#"))
    df = pd.read_csv(src, comment="#")
    df = edit(df)
    Path(dst).write_text(header + df.to_csv(index=False))
    return dst


def test_duplicated_mean_row_of_a_sweep(cli_outputs, tmp_path, capsys):
    def dup(df):
        return pd.concat([df, df[df["sideband"] == "mean"].iloc[[5]]], ignore_index=True)
    p = _edit_csv(cli_outputs["sweep"], tmp_path / "dup.csv", dup)
    n = len(pd.read_csv(p, comment="#"))
    for argv in (["thresholds", p], ["align", "--gate", cli_outputs["gate"], "--sweep", p]):
        assert_refused(capsys, argv, [str(p), "column 'sideband'", f"row {n}", "duplicated"],
             [p, cli_outputs["gate"]])


def test_sweep_row_with_A_above_one(cli_outputs, tmp_path, capsys):
    def big(df):
        i = int(np.flatnonzero(df["sideband"] == "mean")[2])
        df.loc[i, "A"] = 1.5
        return df
    p = _edit_csv(cli_outputs["sweep"], tmp_path / "bigA.csv", big)
    assert_refused(capsys, ["thresholds", p], [str(p), "column 'A'", "1.5"], [p])


# ----------------------------------------------------------------------------- gate tables


def _fidelity(rates, out):
    return ["fidelity", "--populations", CAMP / "populations.csv",
            "--parity", CAMP / "parity.csv", "--gate-rates", rates, "-o", out]


def test_duplicated_gate_rate_row(tmp_path, capsys):
    p = _edit_csv(CAMP / "gate_rates.csv", tmp_path / "rates.csv",
                  lambda df: pd.concat([df, df.iloc[[1]]], ignore_index=True))
    n = len(pd.read_csv(p))
    assert_refused(capsys, _fidelity(p, tmp_path / "g.csv"), [str(p), f"row {n}", "duplicated"], [p])
    assert not (tmp_path / "g.csv").exists()


@pytest.mark.parametrize("col, value", [("A", 1.5), ("xi0_khz", 0.0), ("xi0_khz", -3.0)])
def test_gate_rate_out_of_range(tmp_path, capsys, col, value):
    def edit(df):
        df.loc[0, col] = value
        return df
    p = _edit_csv(CAMP / "gate_rates.csv", tmp_path / "rates.csv", edit)
    assert_refused(capsys, _fidelity(p, tmp_path / "g.csv"), [str(p), f"column '{col}'", "row 1"], [p])
    assert not (tmp_path / "g.csv").exists()


@pytest.mark.parametrize("col, value", [("F", 1.7), ("A", 1.5), ("xi0_khz", 0.0)])
def test_align_gate_table_out_of_range(cli_outputs, tmp_path, capsys, col, value):
    def edit(df):
        df.loc[1, col] = value
        return df
    p = _edit_csv(cli_outputs["gate"], tmp_path / "gate.csv", edit)
    assert_refused(capsys, ["align", "--gate", p, "--sweep", cli_outputs["sweep"]],
         [str(p), f"column '{col}'", "row 2"], [p, cli_outputs["sweep"]])


def test_align_gate_table_duplicated_row(cli_outputs, tmp_path, capsys):
    p = _edit_csv(cli_outputs["gate"], tmp_path / "gate.csv",
                  lambda df: pd.concat([df, df.iloc[[0]]], ignore_index=True))
    n = len(pd.read_csv(p))
    assert_refused(capsys, ["align", "--gate", p, "--sweep", cli_outputs["sweep"]],
         [str(p), f"row {n}", "duplicated"], [p, cli_outputs["sweep"]])


# ----------------------------------------------------------------------------- time scans


def _time_scan_counts_above_shots(tmp_path, with_n01_10):
    """A copy of the bundled campaign whose first time-scan row counts 900 of 625 shots:
    the folder, its time_scans.csv and what the one error line must name."""
    camp = tmp_path / "camp"
    shutil.copytree(CAMP, camp)
    ts = camp / "time_scans.csv"
    df = pd.read_csv(ts)
    if not with_n01_10:
        df = df.drop(columns="n01_10")
    df.loc[0, "n00"] = 900
    df.loc[0, "shots"] = 625
    df.to_csv(ts, index=False)
    return camp, ts, [str(ts), "column 'shots'", "row 1", "900", "625"]


@pytest.mark.parametrize("with_n01_10", [True, False])
def test_diagnose_refuses_time_scan_counts_above_shots(tmp_path, capsys, with_n01_10):
    camp, ts, needles = _time_scan_counts_above_shots(tmp_path, with_n01_10)
    assert_refused(capsys, ["diagnose", camp, "--pairs", "0"], needles, [ts])


@pytest.mark.parametrize("with_n01_10", [True, False])
def test_analyze_refuses_time_scan_counts_above_shots_as_diagnose_does(tmp_path, capsys,
                                                                       with_n01_10):
    """At once, when the file is read: no step runs, nothing is written."""
    camp, ts, needles = _time_scan_counts_above_shots(tmp_path, with_n01_10)
    assert_refused(capsys, ["analyze", camp, "-o", tmp_path / "r", "--no-plots"], needles,
                   [ts])
    assert not (tmp_path / "r").exists()


# ----------------------------------------------------------------------------- messages


def test_count_message_has_plain_numbers(tmp_path, capsys):
    pop = tmp_path / "pop.csv"
    pop.write_text("A,dpd,scan,n00,n11,shots,n_even\n0.5,0,a,623.5,1,625,624\n")
    assert_refused(capsys, ["fidelity", "--populations", pop, "--parity", CAMP / "parity.csv"],
         [str(pop), "column 'n00'", "row 1", "count 623.5 is not an integer"], [pop])


def test_polyfit_too_few_points_names_the_file(tmp_path, capsys):
    p = tmp_path / "one.csv"
    p.write_text("A,power\n0.5,0.3\n")
    assert_refused(capsys, ["polyfit", p, "--x", "A", "--y", "power", "--powers", "1:8"],
         [f"{p}: 1 points for 8 coefficients"], [p])


def test_budget_gate_rates_duplicated_row(tmp_path, capsys):
    p = _edit_csv(CAMP / "gate_rates.csv", tmp_path / "rates.csv",
                  lambda df: pd.concat([df, df.iloc[[0]]], ignore_index=True))
    n = len(pd.read_csv(p))
    assert_refused(capsys, ["budget", "--gate-rates", p], [str(p), f"row {n}", "duplicated"], [p])


# ----------------------------------------------------------------------------- the API


def test_api_refuses_nan_settings():
    from dpdfit.fits.alignment import align
    from dpdfit.models.fidelity import estimate
    from dpdfit.models.im_requirements import im_requirements
    nan = float("nan")
    with pytest.raises(InputError, match="nbar"):
        SweepConfig(nbar=nan)
    with pytest.raises(InputError, match="nbar"):
        estimate(np.array([-40.0, 0.0, 0.0, -30.0]), (0, 1, 2, 3), nbar=nan)
    with pytest.raises(InputError, match="nbar"):
        im_requirements(nbar=nan)
    gate = pd.DataFrame({"A": [0.4, 0.6], "dpd": [0, 0], "xi0_khz": [3.0, 4.0],
                         "xi0_err_khz": [0.1, 0.1], "F": [0.9, 0.95], "F_err": [0.01, 0.01]})
    with pytest.raises(InputError, match="sigma_db"):
        align(gate, pd.DataFrame(), nan)
