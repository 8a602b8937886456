"""One campaign-folder reader for analyze and diagnose: required and
optional files and columns, what is left out, bad input in one line."""

import json
import shutil

import pandas as pd
import pytest

from dpdfit.recordings.campaign_folder import META_DEFAULTS, CampaignFolder
from dpdfit.errors import InputError
from tests.helpers.paths import ROOT

BUNDLED = ROOT / "datasets" / "synthetic_campaign"


def _minimal(tmp_path, keep=("campaign.json", "calibration_amplitude.csv", "spectra.csv")):
    dst = tmp_path / "c"
    dst.mkdir()
    for name in keep:
        shutil.copy(BUNDLED / name, dst / name)
    return dst


def test_complete_folder_leaves_nothing_out():
    cf = CampaignFolder(BUNDLED)
    assert cf.left_out() == []
    assert cf.table_run == "R034" and cf.phase_run == "P006"
    assert cf.time_scans is not None and "n01_10" in cf.time_scans.columns


def test_minimal_folder_reads_and_says_what_is_left_out(tmp_path):
    folder = _minimal(tmp_path)
    meta = json.loads((folder / "campaign.json").read_text())
    for k in ("order", "nbar_assumed", "error_model", "phase_run_for_model"):
        meta.pop(k, None)
    (folder / "campaign.json").write_text(json.dumps(meta))
    p = folder / "spectra.csv"
    pd.read_csv(p).drop(columns=["snr_db", "valid"]).to_csv(p, index=False)
    before = {f.name: f.read_bytes() for f in folder.iterdir()}
    cf = CampaignFolder(folder)
    assert cf.meta["order"] == META_DEFAULTS["order"] and "order" in cf.defaults_used
    assert cf.phase_model is None and cf.populations is None and cf.time_scans is None
    assert (cf.spectra["valid"] == 1).all() and "snr_db" not in cf.spectra.columns
    out = "\n".join(cf.left_out())
    for name in ("calibration_phase.csv", "populations.csv", "parity.csv", "gate_rates.csv",
                 "time_scans.csv", "traces.csv", "error_model", "order = 8"):
        assert name in out, name
    assert {f.name: f.read_bytes() for f in folder.iterdir()} == before


def test_time_scans_without_n01_10_are_accepted_and_checked(tmp_path):
    folder = _minimal(tmp_path, ("campaign.json", "calibration_amplitude.csv",
                                 "time_scans.csv"))
    p = folder / "time_scans.csv"
    df = pd.read_csv(p).drop(columns=["n01_10"])
    df.to_csv(p, index=False)
    assert len(CampaignFolder(folder).time_scans) == len(df)
    df.loc[2, "n00"] = df.loc[2, "shots"] + 1
    df.to_csv(p, index=False)
    with pytest.raises(InputError, match=r"time_scans.csv, column 'shots', row 3: .*exceeds"):
        CampaignFolder(folder).time_scans


@pytest.mark.parametrize("edit, match", [
    (lambda f: (f / "campaign.json").unlink(), "campaign.json missing"),
    (lambda f: (f / "campaign.json").write_text("{"), "not valid JSON"),
    (lambda f: (f / "campaign.json").write_text('{"order": "eight"}'), "'order' must be a number"),
    (lambda f: (f / "campaign.json").write_text("[" * 100 + "]" * 100), "nested too deeply"),
    (lambda f: (f / "campaign.json").write_text('{"predistortion_table": {"amplitude_run": '
                                                '[["aom"]]}}'),
     "key 'predistortion_table.amplitude_run' must be a run label .* got a JSON list"),
    (lambda f: (f / "campaign.json").write_text('{"phase_run_for_model": {}}'),
     "key 'phase_run_for_model' must be a run label .* got a JSON object"),
])
def test_bad_campaign_json_is_one_line(tmp_path, edit, match):
    folder = _minimal(tmp_path)
    edit(folder)
    with pytest.raises(InputError, match=match):
        CampaignFolder(folder)


def test_run_labels_of_campaign_json_are_taken_as_the_run_column_holds_them(tmp_path):
    folder = _minimal(tmp_path)
    meta = json.loads((folder / "campaign.json").read_text())
    for value, label in ((None, "latest"), ("R003", "R003"), (3, "3")):
        meta.update(phase_run_for_model=value, predistortion_table={"amplitude_run": value})
        (folder / "campaign.json").write_text(json.dumps(meta))
        camp = CampaignFolder(folder)
        assert (camp.table_run, camp.phase_run) == (label, label)


def test_bad_spectra_rows_are_named(tmp_path):
    folder = _minimal(tmp_path)
    p = folder / "spectra.csv"
    df = pd.read_csv(p)
    df.loc[4, "sideband"] = "green"
    df.to_csv(p, index=False)
    with pytest.raises(InputError, match=r"spectra.csv, column 'sideband', row 5"):
        CampaignFolder(folder).spectra
    # a line pasted twice is still refused: an honest repeat reads differently
    df = pd.read_csv(BUNDLED / "spectra.csv")
    pd.concat([df, df.iloc[[3]]]).to_csv(p, index=False)
    with pytest.raises(InputError, match=r"row 937 .*copies row 4 .*a line pasted twice"):
        CampaignFolder(folder).spectra


def test_missing_required_file_names_it(tmp_path):
    folder = _minimal(tmp_path, ("campaign.json", "spectra.csv"))
    with pytest.raises(InputError, match="calibration_amplitude.csv, which is missing"):
        CampaignFolder(folder).amplitude_runs
