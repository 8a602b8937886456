"""Optional columns stay optional: a calibration without timestamps skips the stability
with the reason, and ``left_out`` names the optional columns a file lacks."""

import json
import shutil

import pandas as pd

from dpdfit.pipeline.context import Context, Results
from dpdfit.pipeline.steps import stability_step
from dpdfit.recordings.campaign_folder import CampaignFolder
from tests.helpers.paths import ROOT

CAMP = ROOT / "datasets" / "synthetic_campaign"


def _folder(tmp_path, drop: dict) -> CampaignFolder:
    """campaign.json, the calibrations and the spectra of the bundled campaign, with the
    columns ``drop`` names ({file: [column]}) removed."""
    folder = tmp_path / "camp"
    folder.mkdir()
    for name in ("campaign.json", "calibration_amplitude.csv", "calibration_phase.csv",
                 "spectra.csv", "populations.csv", "gate_rates.csv"):
        shutil.copy(CAMP / name, folder / name)
    for name, cols in drop.items():
        df = pd.read_csv(folder / name, comment="#").drop(columns=cols)
        df.to_csv(folder / name, index=False)
    return CampaignFolder(folder)


def _stability(cf):
    ctx = Context(campaign=cf, results=Results(), formula="exact", figures=None)
    return stability_step(ctx, None), ctx.results.statuses["stability"]


def test_stability_skips_a_calibration_without_timestamps_with_the_reason(tmp_path):
    cf = _folder(tmp_path, {"calibration_amplitude.csv": ["timestamp"],
                            "calibration_phase.csv": ["timestamp"]})
    result, status = _stability(cf)
    assert result is None and status["status"] == "skipped"
    assert "calibration_amplitude.csv has no timestamp column" in status["detail"]
    assert "calibration_phase.csv has no timestamp column" in status["detail"]


def test_stability_runs_the_file_that_has_timestamps(tmp_path):
    cf = _folder(tmp_path, {"calibration_amplitude.csv": ["timestamp"]})
    result, status = _stability(cf)
    assert status["status"] == "ok" and set(result.by_kind) == {"phase"}
    assert "skipped: calibration_amplitude.csv has no timestamp column" in status["detail"]


def test_left_out_names_the_missing_optional_columns(tmp_path):
    cf = _folder(tmp_path, {"calibration_amplitude.csv": ["timestamp", "power_err"],
                            "spectra.csv": ["snr_db"], "populations.csv": ["n00"],
                            "gate_rates.csv": ["xi0_err_khz"]})
    out = cf.left_out()
    for line in ("calibration_amplitude.csv has no optional column power_err, timestamp",
                 "spectra.csv has no optional column snr_db",
                 "populations.csv has no optional column n00",
                 "gate_rates.csv has no optional column xi0_err_khz",
                 "time_scans.csv absent"):
        assert any(line in o for o in out), (line, out)
    assert not any("calibration_phase.csv has" in o for o in out)
    json.dumps(out)


def test_left_out_of_a_populations_file_with_the_three_counts_but_no_n_even(tmp_path):
    cf = _folder(tmp_path, {"populations.csv": ["n_even"]})
    assert not any("populations.csv has" in o for o in cf.left_out())


def test_an_analysis_says_what_a_missing_column_costs_in_the_one_line_for_it(tmp_path):
    cf = _folder(tmp_path, {"spectra.csv": ["snr_db"], "populations.csv": ["n00", "n01_10"]})
    out = cf.left_out({("spectra", ("snr_db",)): "noise floor estimated",
                       ("populations", ("n00", "n11")): "imbalance not used"})
    spectra = [o for o in out if o.startswith("spectra.csv")]
    assert spectra == ["spectra.csv has no snr_db: noise floor estimated"]
    pop = [o for o in out if o.startswith("populations.csv")]
    # the group's line, then the generic line for the column outside the group
    assert pop == ["populations.csv has no n00/n11: imbalance not used",
                   "populations.csv has no optional column n01_10"]
