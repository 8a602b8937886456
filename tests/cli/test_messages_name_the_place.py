"""Every message names its file (and row), so a user can find what to fix.

* not-invertible and ``y(1) <= 0`` calibrations, bad alignment uncertainties:
  the file (and column/row) in the one line;
* rows identical in every column (a line pasted twice) refused by
  ``calibrate``, ``stability``, ``align`` and ``budget``, naming both rows;
* ``calibrate`` refuses a non-invertible amplitude fit and writes nothing;
* parity phases in degrees: refused, naming file and column;
* a row's message gives the file's line number, right with ``#`` comments and
  blank lines before the data;
* the public readers raise :class:`~dpdfit.errors.DpdfitError` (never
  IsADirectoryError, KeyError, UnicodeDecodeError) for a directory, a missing
  file, an empty file and a JSON with a missing key.
"""

import json
import logging
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import dpdfit
from dpdfit.analyses.budget import gate_rates_khz, load_budget_config
from dpdfit.analyses.stability import stability
from dpdfit.analyses.sweep import read_sweep_table
from dpdfit.cli.main import main
from tests.helpers.cli_refusal import assert_refused
from dpdfit.errors import (DpdfitError, ImplausibleValueError, InputError, NotInvertibleError,
                           data_line)
from dpdfit.recordings.counts import read_parity
from dpdfit.recordings.plausibility import DEGREES_SPAN_RAD
from dpdfit.recordings.tables import read_table
from tests.helpers.paths import ROOT

AMP = ROOT / "datasets" / "synthetic_aom" / "calibration_amplitude.csv"
PHASE = ROOT / "datasets" / "synthetic_aom" / "calibration_phase.csv"
CAMP = ROOT / "datasets" / "synthetic_campaign"


def _bad_calibration(tmp_path, coefficients, name):
    """A calibration.json with the amplitude polynomial ``coefficients`` (powers 1..K)."""
    k = len(coefficients)
    cal = {"amplitude": {"powers": list(range(1, k + 1)), "coefficients": coefficients,
                         "stderr": [0] * k, "covariance": [[0] * k] * k, "monotone": False}}
    p = tmp_path / name
    p.write_text(json.dumps(cal))
    return p


def _with_line_repeated(src: Path, dst: Path, data_row: int) -> Path:
    """``src`` with data row ``data_row`` (1-based, no comments in between) pasted twice."""
    lines = src.read_text().splitlines(keepends=True)
    first = next(i for i, s in enumerate(lines) if not s.startswith("#"))  # the header
    i = first + data_row
    dst.write_text("".join(lines[:i + 1] + [lines[i]] + lines[i + 1:]))
    return dst


# ----------------------------------------------------------------------------- 1. file named


def test_not_invertible_calibration_is_named_by_file(tmp_path, capsys):
    p = _bad_calibration(tmp_path, [1.0, -2.0, 1.25], "bad_cal.json")
    for argv in (["lut", p, "-o", tmp_path / "lut.csv"], ["sweep", p, "-o", tmp_path / "s.csv"]):
        line = assert_refused(capsys, argv, [f"error: {p}: amplitude fit is not invertible",
                                   "dy/dA <= 0 at A = 0.400000", "[0.4000, 0.6667]"], [p])
        assert "np.float64" not in line
    assert not (tmp_path / "lut.csv").exists() and not (tmp_path / "s.csv").exists()
    tf = dpdfit.TransferFunction.from_calibration(dpdfit.load_calibration(p))
    with pytest.raises(NotInvertibleError) as exc:
        tf.invertibility()
    assert str(exc.value).startswith(f"{p}: ") and exc.value.amplitude == pytest.approx(0.4)


def test_negative_full_drive_amplitude_is_named_by_file(tmp_path, capsys):
    p = _bad_calibration(tmp_path, [1.0, -2.0, 0.5], "neg_cal.json")
    assert_refused(capsys, ["lut", p, "-o", tmp_path / "lut.csv"],
         [f"error: {p}: fitted y(1) = -0.5 <= 0"], [p])


def test_a_transfer_function_without_source_keeps_its_plain_message():
    tf = dpdfit.TransferFunction((1, 2, 3), (1.0, -2.0, 1.25))
    with pytest.raises(NotInvertibleError, match=r"^amplitude fit is not invertible"):
        tf.invertibility()


@pytest.mark.parametrize("col, value, need", [("F_err", 0.0, "> 0"),
                                               ("xi0_err_khz", -1.0, ">= 0")])
def test_align_names_file_column_and_row_of_a_bad_uncertainty(cli_outputs, tmp_path, capsys,
                                                              col, value, need):
    g = pd.read_csv(cli_outputs["gate"])
    g.loc[2, col] = value
    p = tmp_path / "gate.csv"
    g.to_csv(p, index=False)
    assert_refused(capsys, ["align", "--gate", p, "--sweep", cli_outputs["sweep"]],
         [str(p), f"column '{col}'", "row 3", f"must be {need}", "(line 4)"], [p])


# ----------------------------------------------------------------------------- 2. duplicates


def test_calibrate_refuses_a_line_pasted_twice(tmp_path, capsys):
    # AMP: one comment line, the header, then data; data row 4 is line 6
    p = _with_line_repeated(AMP, tmp_path / "amp.csv", 4)
    for extra in ([], ["--all-runs"]):
        assert_refused(capsys, ["calibrate", "--amplitude", p, "-o", tmp_path / "c.json", *extra],
             [str(p), "row 5: repeats row 4 (line 6) in every column", "(line 7)"], [p])
    assert not (tmp_path / "c.json").exists()
    q = _with_line_repeated(PHASE, tmp_path / "phase.csv", 10)
    assert_refused(capsys, ["calibrate", "--amplitude", AMP, "--phase", q, "-o", tmp_path / "c.json"],
         [str(q), "row 11: repeats row 10", "in every column"], [q])
    with pytest.raises(InputError) as exc:
        dpdfit.read_calibration(p, "amplitude")
    assert exc.value.row == 5 and exc.value.line == 7


def test_repeated_amplitudes_with_different_readings_stay_accepted(tmp_path, capsys):
    lines = AMP.read_text().splitlines(keepends=True)
    row = lines[5].rstrip("\n").split(",")          # data row 4
    row[3] = repr(float(row[3]) + 1e-5)             # same run, timestamp, A; power differs
    p = tmp_path / "amp.csv"
    p.write_text("".join(lines[:6]) + ",".join(row) + "\n" + "".join(lines[6:]))
    assert main(["calibrate", "--amplitude", str(p), "-o", str(tmp_path / "c.json"),
                 "--order-scan", "none"]) == 0, capsys.readouterr().err
    data = dpdfit.read_calibration(p, "amplitude")
    assert np.sum(data.A == data.A[3]) == 2


def test_stability_refuses_a_line_pasted_twice(tmp_path, capsys):
    p = _with_line_repeated(CAMP / "calibration_amplitude.csv", tmp_path / "runs.csv", 7)
    assert_refused(capsys, ["stability", p], [str(p), "row 8: repeats row 7", "in every column"], [p])
    df = pd.read_csv(p)
    with pytest.raises(InputError, match="row 8: repeats row 7 in every column"):
        stability(df)


def test_align_and_budget_refuse_a_line_pasted_twice(cli_outputs, tmp_path, capsys):
    g = _with_line_repeated(cli_outputs["gate"], tmp_path / "gate.csv", 2)
    assert_refused(capsys, ["align", "--gate", g, "--sweep", cli_outputs["sweep"]],
         [str(g), "row 3", "repeats row 2", "duplicated line"], [g])
    s = _with_line_repeated(cli_outputs["sweep"], tmp_path / "sweep.csv", 6)
    l6, l7 = data_line(s, 6), data_line(s, 7)      # sweep.csv starts with '#' header lines
    text = s.read_text().splitlines()
    assert l7 == l6 + 1 and l6 > 7 and text[l6 - 1] == text[l7 - 1]
    assert_refused(capsys, ["align", "--gate", cli_outputs["gate"], "--sweep", s],
         [str(s), "row 7", f"repeats row 6 (line {l6})", "duplicated line", f"(line {l7})"], [s])
    r = _with_line_repeated(CAMP / "gate_rates.csv", tmp_path / "rates.csv", 1)
    assert_refused(capsys, ["budget", "--gate-rates", r],
         [str(r), "row 2", "repeats row 1", "duplicated line"], [r])


def test_bundled_tables_have_no_line_pasted_twice():
    files = sorted(p for p in (ROOT / "datasets").rglob("*.csv") if p.read_text().strip())
    assert len(files) >= 15
    for p in files:
        read_table(p, [], distinct_rows=True)
    for p in (AMP, CAMP / "calibration_amplitude.csv"):
        assert len(dpdfit.read_calibration(p, "amplitude", "latest").A) > 50


# ----------------------------------------------------------------------------- 3. calibrate


def test_calibrate_refuses_a_non_invertible_fit_and_writes_nothing(tmp_path, capsys):
    # y = A - 2 A^2 + 1.25 A^3: local maximum y(0.4) = 0.16 below y(1) = 0.25
    A = np.linspace(0, 1, 101)
    y = A - 2 * A ** 2 + 1.25 * A ** 3
    P = 3 * y ** 2 + np.random.default_rng(1).normal(0, 1e-4, A.size)
    p = tmp_path / "amp.csv"
    p.write_text("A,power,power_err\n" + "".join(f"{a:g},{v:.8g},0.0001\n" for a, v in zip(A, P)))
    out = tmp_path / "c.json"
    line = assert_refused(capsys, ["calibrate", "--amplitude", p, "-o", out, "--plot", tmp_path / "fig"],
                [f"error: {p}: amplitude fit is not invertible", "dy/dA <= 0 at A = 0.4",
                 "dy/dA < 0 on [0.4", "nothing written"], [p])
    assert "0.666" in line or "0.667" in line
    assert not out.exists() and not (tmp_path / "fig").exists()


# ----------------------------------------------------------------------------- 4. degrees


def test_parity_phases_in_degrees_are_refused(tmp_path, caplog):
    d = pd.read_csv(CAMP / "parity.csv", comment="#")
    d["phase_rad"] = np.degrees(d["phase_rad"])
    p = tmp_path / "parity_deg.csv"
    d.to_csv(p, index=False)
    with pytest.raises(ImplausibleValueError) as exc:
        read_parity(p)
    msg = str(exc.value)
    assert str(p) in msg and "column 'phase_rad'" in msg and "in degrees?" in msg
    assert "\n" not in msg
    with caplog.at_level(logging.WARNING, logger="dpdfit"):
        read_parity(CAMP / "parity.csv")
    assert not [r for r in caplog.records if "degrees" in r.getMessage()]
    assert DEGREES_SPAN_RAD == pytest.approx(4 * math.pi)


def test_degrees_refusal_reaches_the_cli(tmp_path, capsys):
    d = pd.read_csv(CAMP / "parity.csv", comment="#")
    d["phase_rad"] = np.degrees(d["phase_rad"])
    p = tmp_path / "parity_deg.csv"
    d.to_csv(p, index=False)
    assert_refused(capsys, ["fidelity", "--populations", CAMP / "populations.csv", "--parity", p],
                   [f"{p}, column 'phase_rad'", "in degrees?"], [p])


# ----------------------------------------------------------------------------- 5. lines


def test_rows_and_lines_with_comments_and_blank_lines(tmp_path, capsys):
    p = tmp_path / "amp.csv"
    p.write_text("# comment\n\nA,power\n   \n0.1,1\n# another\n0.2,nan\n0.3,2\n")
    with pytest.raises(InputError) as exc:
        read_table(p, ["A", "power"])
    assert exc.value.row == 2 and exc.value.line == 7
    assert str(exc.value) == f"{p}, column 'power', row 2: value is NaN (line 7)"
    assert p.read_text().splitlines()[exc.value.line - 1] == "0.2,nan"
    assert_refused(capsys, ["polyfit", p, "--x", "A", "--y", "power", "--powers", "0:1"],
         ["row 2: value is NaN (line 7)"], [p])


def test_data_line_of_headerless_and_binary_files(tmp_path):
    t = tmp_path / "trace.csv"
    t.write_text("# a trace\n1.0\n\n2.0\nnan\n")
    assert [data_line(t, r) for r in (1, 2, 3, 4)] == [2, 4, 5, None]
    with pytest.raises(InputError) as exc:
        dpdfit.load_trace(t)
    assert exc.value.row == 3 and exc.value.line == 5
    n = tmp_path / "x.npy"
    np.save(n, np.array([1.0, np.nan]))
    assert data_line(n, 1) is None and data_line(tmp_path, 1) is None
    with pytest.raises(InputError) as exc:
        dpdfit.load_trace(n)
    assert exc.value.row == 2 and exc.value.line is None and "(line" not in str(exc.value)
    assert InputError("x", file="no/such/file.csv", row=3).line is None


# ----------------------------------------------------------------------------- 6. typed errors


READERS = {
    "read_table": lambda p: dpdfit.read_table(p, ["A"]),
    "read_calibration": lambda p: dpdfit.read_calibration(p, "amplitude"),
    "load_calibration": dpdfit.load_calibration,
    "read_populations": dpdfit.read_populations,
    "read_parity": dpdfit.read_parity,
    "load_trace": dpdfit.load_trace,
    "read_sweep_table": read_sweep_table,
    "gate_rates_khz": gate_rates_khz,
    "load_budget_config": load_budget_config,
    "analyze": dpdfit.analyze,
}


def _inputs(tmp_path):
    d = tmp_path / "a_folder.csv"
    d.mkdir()
    empty = tmp_path / "empty.csv"
    empty.write_text("")
    nokey = tmp_path / "nokey.json"
    nokey.write_text(json.dumps({"amplitude": {"powers": [1, 2], "coefficients": [1, -0.1],
                                               "covariance": [[0, 0], [0, 0]]}}))
    binary = tmp_path / "binary.csv"
    binary.write_bytes(bytes(range(128, 256)) * 8)
    return {"directory": d, "missing": tmp_path / "missing.csv", "empty": empty,
            "json_missing_key": nokey, "binary": binary}


@pytest.mark.parametrize("reader", list(READERS))
@pytest.mark.parametrize("case", ["directory", "missing", "empty", "json_missing_key",
                                  "binary"])
def test_public_readers_raise_typed_errors_naming_the_file(tmp_path, reader, case):
    path = _inputs(tmp_path)[case]
    if reader == "load_budget_config" and case == "empty":
        assert load_budget_config(path)["delta"] is not None  # every key is optional
        return
    with pytest.raises(DpdfitError) as exc:
        READERS[reader](path)
    assert str(path) in str(exc.value), str(exc.value)
    assert "np.float64" not in str(exc.value)


def test_load_calibration_with_a_missing_key_names_file_and_key(tmp_path):
    p = _inputs(tmp_path)["json_missing_key"]
    with pytest.raises(InputError, match="monotone|stderr") as exc:
        dpdfit.load_calibration(p)
    assert exc.value.file == str(p)


def test_align_names_the_gate_row_outside_the_sweep(cli_outputs, tmp_path, capsys):
    narrow = tmp_path / "narrow.csv"
    assert main(["sweep", str(cli_outputs["cal"]), "-o", str(narrow),
                 "--amplitudes", "0.5:1:11"]) == 0
    capsys.readouterr()
    assert_refused(capsys, ["align", "--gate", cli_outputs["gate"], "--sweep", narrow],
         [str(cli_outputs["gate"]), "column 'A', row 1",
          "A=0.4 is outside the sweep's range [0.5, 1]", "(line 2)"], [cli_outputs["gate"], narrow])


def test_campaign_folder_refuses_a_calibration_line_pasted_twice(tmp_path):
    from dpdfit.recordings.campaign_folder import CampaignFolder
    camp = tmp_path / "camp"
    camp.mkdir()
    (camp / "campaign.json").write_text((CAMP / "campaign.json").read_text())
    _with_line_repeated(CAMP / "calibration_amplitude.csv", camp / "calibration_amplitude.csv", 3)
    with pytest.raises(InputError, match="row 4: repeats row 3 .*in every column"):
        CampaignFolder(camp).amplitude_runs


def test_count_files_name_the_lines_of_both_repeated_rows(tmp_path):
    par = _with_line_repeated(CAMP / "parity.csv", tmp_path / "parity.csv", 2)
    with pytest.raises(InputError) as exc:
        read_parity(par)
    assert exc.value.row == 3 and exc.value.line == data_line(par, 3)
    assert f"rows 2, 3 (lines {data_line(par, 2)}, {data_line(par, 3)})" in str(exc.value)
    text = par.read_text().splitlines()
    assert text[data_line(par, 2) - 1] == text[data_line(par, 3) - 1]
    pop = _with_line_repeated(CAMP / "populations.csv", tmp_path / "populations.csv", 2)
    with pytest.raises(InputError, match=r"rows 2, 3 \(lines \d+, \d+\)"):
        dpdfit.read_populations(pop)
