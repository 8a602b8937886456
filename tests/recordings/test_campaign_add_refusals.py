"""``dpdfit add`` on bad input: one line naming file, column and row (or key), exit 2,
nothing written (the output folder not created), CAMPAIGN and NEW unchanged."""

from __future__ import annotations

import json
import shutil

import pandas as pd
import pytest

from dpdfit.simulation.campaign import campaign_hashes
from tests.helpers.cli_refusal import assert_refused
from tests.helpers.further_campaign import simulate

ROWS = {"populations": "A,dpd,scan,n00,n01_10,n11,n_even,shots\n0.4,1,1,100,2,198,298,300\n",
        "gate_rates": "A,dpd,xi0_khz,xi0_err_khz\n0.4,1,5.1,0.05\n"}


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    return simulate(tmp_path_factory.mktemp("refusals") / "campaign")


def _new(tmp_path, files: dict, meta: dict | None = None):
    new = tmp_path / "new"
    new.mkdir()
    for name, text in files.items():
        (new / (name if "." in name else f"{name}.csv")).write_text(text)
    if meta is not None:
        (new / "campaign.json").write_text(json.dumps(meta))
    return new


def _refused(capsys, campaign, new, out, needles):
    before = campaign_hashes(campaign)
    inputs = [p for p in new.rglob("*") if p.is_file()] if new.is_dir() else [new]
    line = assert_refused(capsys, ["add", campaign, new, "-o", out], needles, inputs=inputs)
    assert campaign_hashes(campaign) == before
    assert not out.exists() or out == campaign or not any(out.iterdir())
    assert not [p for p in out.parent.iterdir() if p.name.startswith(f".{out.name}.")]
    return line


@pytest.mark.parametrize("key, value, needle", [
    ("nu_hz", 1.85e6, "another campaign (another gate detuning)"),
    ("eta_ld", 0.03, "another campaign (another ion setup)"),
    ("predistortion_table", {"amplitude_run": "R001"}, "predistortion table"),
])
def test_recordings_of_another_campaign(campaign, tmp_path, capsys, key, value, needle):
    meta = json.loads((campaign / "campaign.json").read_text())
    meta[key] = value
    new = _new(tmp_path, ROWS, meta)
    line = _refused(capsys, campaign, new, tmp_path / "out", [needle, "campaign.json"])
    assert f"'{key}" in line


def test_another_campaign_named_by_the_mapping_line(campaign, tmp_path, capsys):
    mapping = tmp_path / "map.toml"
    mapping.write_text('[campaign]\nname = "x"\nnu_hz = 2.0e6\n\n[[gate_rates]]\n'
                       'files = "*.h5"\n[gate_rates.columns]\nA = 0.4\ndpd = 0\n'
                       'xi0_khz = 5.0\n')
    _refused(capsys, campaign, mapping, tmp_path / "out",
             ["map.toml", "[campaign] nu_hz (line 3)", "another campaign"])


@pytest.mark.parametrize("table, text, column, row", [
    ("populations", "A,dpd,scan,n_even,shots\n0.4,1,1,3,5\n1.2,1,2,3,5\n", "A", 2),
    ("parity", "A,dpd,scan,phase_rad,n_even,shots\n0.4,2,1,0,3,5\n", "dpd", 1),
    ("time_scans", "A,dpd,t_us,n00,n11,shots\n0.4,0.5,0,3,1,5\n", "dpd", 1),
])
def test_a_setting_the_campaign_cannot_model(campaign, tmp_path, capsys, table, text,
                                             column, row):
    new = _new(tmp_path, {table: text})
    _refused(capsys, campaign, new, tmp_path / "out",
             [f"{new / table}.csv", f"column '{column}'", f"row {row}",
              "the campaign cannot model this setting"])


def test_a_run_label_taken_with_other_data(campaign, tmp_path, capsys):
    amp = pd.read_csv(campaign / "calibration_amplitude.csv")
    run = amp[amp["run"] == "R002"].copy()
    run["power"] = run["power"] * 1.01
    new = _new(tmp_path, {"calibration_amplitude": run.to_csv(index=False)})
    _refused(capsys, campaign, new, tmp_path / "out",
             ["calibration_amplitude.csv", "column 'run', row 1", "run 'R002' exists",
              "column 'power'"])


def test_an_output_folder_that_exists_even_empty(campaign, tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    _refused(capsys, campaign, _new(tmp_path, ROWS), out, ["exists", str(out)])


@pytest.mark.parametrize("where", ["inside", "itself"])
def test_an_output_folder_inside_the_campaign(campaign, tmp_path, capsys, where):
    out = campaign / "plus" if where == "inside" else campaign
    _refused(capsys, campaign, _new(tmp_path, ROWS), out,
             ["inside the campaign folder" if where == "inside" else "exists"])
    assert not (campaign / "plus").exists()


def test_an_output_folder_inside_new_and_new_the_campaign(campaign, tmp_path, capsys):
    new = _new(tmp_path, ROWS)
    _refused(capsys, campaign, new, new / "out", ["inside NEW"])
    _refused(capsys, campaign, campaign, tmp_path / "out", ["NEW is the campaign folder"])


def test_nothing_to_add(campaign, tmp_path, capsys):
    _refused(capsys, campaign, _new(tmp_path, {}), tmp_path / "out", ["nothing to add"])
    shutil.rmtree(tmp_path / "new")
    amp = pd.read_csv(campaign / "calibration_amplitude.csv", dtype=str)
    new = _new(tmp_path, {"calibration_amplitude": amp[amp["run"] == "R001"].to_csv(
        index=False)})
    _refused(capsys, campaign, new, tmp_path / "out",
             ["nothing to add", "every calibration run is in the campaign already"])


def test_traces_and_a_missing_column_are_refused(campaign, tmp_path, capsys):
    new = _new(tmp_path, {**ROWS, "traces.csv": "file,A,dpd,fs,fdet,nu,xi0\n"})
    _refused(capsys, campaign, new, tmp_path / "out", ["traces.csv", "not raw traces"])
    shutil.rmtree(new)
    new = _new(tmp_path, {"populations": "A,dpd,scan,n00,n11,n_even,shots\n"
                                         "0.4,1,1,100,198,298,300\n"})
    _refused(capsys, campaign, new, tmp_path / "out",
             [f"{new / 'populations.csv'}", "has no column 'n01_10'"])


def test_a_value_the_readers_refuse_names_new_file_and_row(campaign, tmp_path, capsys):
    new = _new(tmp_path, {"populations": "A,dpd,scan,n00,n01_10,n11,n_even,shots\n"
                                         "0.4,1,1,100,2,198,298,300\n"
                                         "0.4,1,2,100,2,298,398,300\n"})
    _refused(capsys, campaign, new, tmp_path / "out",
             [f"{new / 'populations.csv'}", "row 2", "added as row"])
