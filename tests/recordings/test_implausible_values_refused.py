"""Values no real campaign holds (unit slips) are refused at the campaign boundary.

A gate rate above the mode frequency or 10x away from the spectra's gate
detuning, shots below 1, phases spanning degrees, an amplitude ``A`` outside
[0, 1]: one :class:`~dpdfit.errors.ImplausibleValueError` line naming the value,
the file, column and row and the likely slip, through the readers of
:class:`~dpdfit.recordings.campaign_folder.CampaignFolder` (which the import reads
back through too); ``dpdfit analyze`` and ``dpdfit diagnose`` refuse such a
campaign as a whole, exit 2, nothing written.  The bundled datasets and the
validation campaigns all pass.
"""

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import dpdfit
from dpdfit.analyses.stability import stability
from dpdfit.errors import ImplausibleValueError, InputError
from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.recordings.counts import read_parity
from dpdfit.recordings.plausibility import DEGREES_SPAN_RAD, RATE_SPECTRA_FACTOR
from dpdfit.recordings.tables import read_calibration
from tests.helpers.cli_refusal import assert_refused
from tests.helpers.paths import ROOT

CAMP = ROOT / "datasets" / "synthetic_campaign"
SHARED = ROOT.parent / "shared"
TABLES = ["calibration_amplitude.csv", "calibration_phase.csv", "spectra.csv",
          "populations.csv", "parity.csv", "gate_rates.csv", "time_scans.csv", "traces.csv"]
#: the CampaignFolder attribute that reads each table
READS = {"calibration_amplitude.csv": "amplitude_runs", "calibration_phase.csv": "phase_runs",
         "spectra.csv": "spectra", "populations.csv": "populations", "parity.csv": "parity",
         "gate_rates.csv": "gate_rates", "time_scans.csv": "time_scans",
         "traces.csv": "traces"}


def _campaign(tmp_path) -> Path:
    """The bundled campaign's files (not its raw trace files) in a new folder."""
    folder = tmp_path / "campaign"
    folder.mkdir()
    for p in CAMP.iterdir():
        if p.is_file():
            shutil.copy(p, folder / p.name)
    return folder


def _edit(folder: Path, name: str, change) -> Path:
    """Rewrite table ``name`` of ``folder`` with ``change(df)`` applied; its path."""
    path = folder / name
    df = pd.read_csv(path, comment="#")
    change(df)
    df.to_csv(path, index=False)
    return path


def _edit_meta(folder: Path, **keys) -> None:
    path = folder / "campaign.json"
    meta = json.loads(path.read_text())
    for k, v in keys.items():
        if v is None:
            meta.pop(k, None)
        else:
            meta[k] = v
    path.write_text(json.dumps(meta))


def _rates_in_hz(folder: Path) -> Path:
    """gate_rates.csv with the rates stored in Hz under the kHz label (the user's slip)."""
    def change(df):
        df["xi0_khz"] *= 1000
        df["xi0_err_khz"] *= 1000
    return _edit(folder, "gate_rates.csv", change)


def _refused(folder: Path, attr: str) -> str:
    with pytest.raises(ImplausibleValueError) as exc:
        getattr(CampaignFolder(folder), attr)
    msg = str(exc.value)
    assert "\n" not in msg
    return msg


# ----------------------------------------------------------------------------- gate rates


def test_gate_rate_stored_in_hz_exceeds_the_mode_frequency(tmp_path):
    path = _rates_in_hz(_campaign(tmp_path))
    msg = _refused(path.parent, "gate_rates")
    assert msg == (f"{path}, column 'xi0_khz', row 1: gate rate 3349 kHz exceeds the mode "
                   "frequency 1840 kHz (campaign.json nu_hz): stored in Hz with unit kHz? "
                   "(line 2)")


def test_gate_rate_stored_in_mhz_is_far_below_the_spectra_detuning(tmp_path):
    path = _edit(_campaign(tmp_path), "gate_rates.csv",
                 lambda df: df.__setitem__("xi0_khz", df["xi0_khz"] / 1000))
    msg = _refused(path.parent, "gate_rates")
    assert f"{path}, column 'xi0_khz', row 1: gate rate 0.003349 kHz is 5.97e+03x below" in msg
    assert "gate detuning 20 kHz (campaign.json xi0_spectra_hz)" in msg
    assert "stored in MHz with unit kHz" in msg


def test_gate_rate_ten_times_the_spectra_detuning_is_refused(tmp_path):
    folder = _campaign(tmp_path)
    _edit(folder, "gate_rates.csv", lambda df: df.__setitem__("xi0_khz", np.where(
        df.index == 2, 1.01 * RATE_SPECTRA_FACTOR * 20, df["xi0_khz"])))
    msg = _refused(folder, "gate_rates")
    assert "row 3: gate rate 202 kHz is 10.1x above the spectra's gate detuning 20 kHz" in msg
    assert "stored in Hz with unit kHz, or a wrong xi0_spectra_hz?" in msg


def test_mode_frequency_in_khz_is_named_as_the_slip(tmp_path):
    folder = _campaign(tmp_path)
    _edit_meta(folder, nu_hz=1840)
    msg = _refused(folder, "gate_rates")
    assert "exceeds the mode frequency 1.84 kHz (campaign.json nu_hz): nu_hz written in kHz" in msg


def test_a_defaulted_mode_frequency_is_named_as_the_default(tmp_path):
    folder = _campaign(tmp_path)
    _rates_in_hz(folder)
    _edit_meta(folder, nu_hz=None)
    assert "(campaign.json's default nu_hz, absent from the file)" in _refused(folder,
                                                                               "gate_rates")


@pytest.mark.parametrize("key", ["nu_hz", "xi0_spectra_hz"])
def test_non_positive_campaign_frequencies_are_refused(tmp_path, key):
    folder = _campaign(tmp_path)
    _edit_meta(folder, **{key: 0.0})
    with pytest.raises(InputError, match=rf"campaign\.json: key '{key}' must be > 0 \(Hz\)"):
        CampaignFolder(folder).gate_rates


# ----------------------------------------------------------------------------- shots


@pytest.mark.parametrize("name", ["populations.csv", "parity.csv", "time_scans.csv"])
@pytest.mark.parametrize("shots", [0, 0.5])
def test_shots_below_one_are_refused(tmp_path, name, shots):
    folder = _campaign(tmp_path)
    path = _edit(folder, name, lambda df: df.__setitem__(
        "shots", np.where(df.index == 3, shots, df["shots"])))
    msg = _refused(folder, READS[name])
    assert msg.startswith(f"{path}, column 'shots', row 4: shots = {shots:g} is below 1 "
                          "(a row with no shots): an aborted scan, or a fraction")


# ----------------------------------------------------------------------------- degrees


def _degrees(df):
    df["phase_rad"] = np.degrees(df["phase_rad"])


def test_parity_phases_in_degrees_are_refused(tmp_path):
    folder = _campaign(tmp_path)
    path = _edit(folder, "parity.csv", _degrees)
    msg = _refused(folder, "parity")
    assert msg.startswith(f"{path}, column 'phase_rad', row 16: the phases of setting A=0.4, "
                          "dpd=0, scan 1 span 0 to 337.5 (337.5), more than 4*pi = 12.57 rad: "
                          "in degrees?")


def test_calibration_phases_in_degrees_are_refused(tmp_path):
    folder = _campaign(tmp_path)
    path = _edit(folder, "calibration_phase.csv", _degrees)
    msg = _refused(folder, "phase_runs")
    assert f"{path}, column 'phase_rad', row " in msg
    assert "the phases of run P001 span" in msg and "in degrees?" in msg
    for read in (lambda: read_calibration(path, "phase", "latest"),
                 lambda: stability(path, "phase")):
        with pytest.raises(ImplausibleValueError, match="in degrees"):
            read()


def test_a_calibration_without_runs_is_checked_as_one(tmp_path):
    p = tmp_path / "phase.csv"
    p.write_text("A,phase_rad\n" + "".join(f"{a:.2f},{60 * a:.3f}\n"
                                          for a in np.linspace(0, 1, 11)))
    with pytest.raises(ImplausibleValueError, match="the phases of the calibration span 0 to 60"):
        read_calibration(p, "phase")


def test_radian_scans_up_to_four_pi_pass(tmp_path):
    rows = ["A,dpd,scan,phase_rad,n_even,shots"]
    for k, phi in enumerate(np.linspace(0, 4 * math.pi - 0.05, 32)):
        rows.append(f"0.5,0,1,{phi:.6f},{300 + k},625")
    p = tmp_path / "parity.csv"
    p.write_text("\n".join(rows) + "\n")
    assert len(read_parity(p)) == 32
    assert DEGREES_SPAN_RAD == pytest.approx(4 * math.pi)


# ----------------------------------------------------------------------------- amplitude


@pytest.mark.parametrize("name", TABLES)
def test_amplitude_in_percent_is_refused_in_every_table(tmp_path, name):
    folder = _campaign(tmp_path)
    path = _edit(folder, name, lambda df: df.__setitem__("A", df["A"] * 100))
    msg = _refused(folder, READS[name])
    assert msg.startswith(f"{path}, column 'A', row ")
    assert ("is outside [0, 1]: A is the normalised RF amplitude (1 = maximum diffraction): "
            "a percentage, a DAC value or dB in its place?") in msg


# ----------------------------------------------------------------------------- the boundary


def test_bundled_datasets_pass():
    for folder in (CAMP, ROOT / "datasets" / "concealed_campaign"):
        CampaignFolder(folder).check_plausible()
    for kind in ("amplitude", "phase"):
        read_calibration(ROOT / "datasets" / "synthetic_aom" / f"calibration_{kind}.csv",
                         kind, "latest")


@pytest.mark.skipif(not (SHARED / "validation_campaigns").is_dir(),
                    reason="the validation campaigns are not beside the repository")
def test_validation_campaigns_pass():
    folders = sorted((SHARED / "validation_campaigns").glob("v*")) + sorted(
        (SHARED / "validation_pairs").glob("p*"))
    assert folders
    for folder in folders:
        CampaignFolder(folder).check_plausible()


def test_a_malformed_file_is_left_to_the_analyses_that_read_it(tmp_path):
    folder = _campaign(tmp_path)
    _edit(folder, "spectra.csv", lambda df: df.__setitem__("P_dB", np.where(
        df.index == 0, np.nan, df["P_dB"])))
    cf = CampaignFolder(folder)
    cf.check_plausible()
    with pytest.raises(InputError, match="value is empty") as exc:
        cf.spectra
    assert not isinstance(exc.value, ImplausibleValueError)


def test_analyze_refuses_the_campaign_before_any_analysis(tmp_path):
    folder = _campaign(tmp_path)
    _edit(folder, "traces.csv", lambda df: df.__setitem__("A", df["A"] * 100))
    out = tmp_path / "results"
    with pytest.raises(ImplausibleValueError, match="traces.csv, column 'A', row 1"):
        dpdfit.analyze(folder, out, plots=False, diagnosis=False, progress=False)
    assert not out.exists()


@pytest.mark.parametrize("command", ["analyze", "diagnose"])
def test_gate_rate_in_hz_is_refused_by_the_command_line(tmp_path, capsys, command):
    path = _rates_in_hz(_campaign(tmp_path))
    out = tmp_path / "out"
    argv = ([command, path.parent, "-o", out] if command == "analyze"
            else [command, path.parent, "--plot", out])
    line = assert_refused(capsys, argv, [
        f"{path}, column 'xi0_khz', row 1: gate rate 3349 kHz exceeds the mode frequency "
        "1840 kHz (campaign.json nu_hz): stored in Hz with unit kHz? (line 2)"],
        [path, path.parent / "campaign.json"])
    assert "Traceback" not in line and "MemoryError" not in line
    assert not out.exists()


@pytest.mark.parametrize("name, change, needle", [
    ("populations.csv", lambda df: df.__setitem__("shots", 0), "shots = 0 is below 1"),
    ("calibration_phase.csv", _degrees, "in degrees?"),
    ("spectra.csv", lambda df: df.__setitem__("A", df["A"] * 100), "normalised RF amplitude"),
])
def test_every_refusal_stops_analyze_with_one_line(tmp_path, capsys, name, change, needle):
    folder = _campaign(tmp_path)
    path = _edit(folder, name, change)
    out = tmp_path / "out"
    assert_refused(capsys, ["analyze", folder, "-o", out, "--no-plots"], [str(path), needle],
                   [path])
    assert not out.exists()
