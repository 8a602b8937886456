"""What ``dpdfit import`` says: each warning once on stderr, after the campaign is
written (so an error is never preceded by warnings), every path relative to the mapping."""

from __future__ import annotations

import pytest

pytest.importorskip("h5py")

from dpdfit.cli.main import main  # noqa: E402
from dpdfit.simulation.artiq_results import write_per_shot_campaign  # noqa: E402
from tests.helpers.paths import ROOT  # noqa: E402

BUNDLED = ROOT / "datasets" / "synthetic_campaign"


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """Per-shot results files with one interrupted parity scan, and their mapping."""
    out = tmp_path_factory.mktemp("per_shot_lab") / "lab"
    write_per_shot_campaign(BUNDLED, out, seed=3)
    return out


def _run(argv, capsys):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, [x for x in err.splitlines() if x.strip()]


def test_a_warning_is_printed_once_on_stderr_with_the_path_relative_to_the_mapping(
        lab, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)                     # the mapping is elsewhere
    code, out, err = _run(["import", lab / "mapping.toml", "-o", "c", "--no-progress"], capsys)
    assert code == 0
    assert "did not complete" not in out
    warned = [x for x in err if "did not complete" in x]
    assert len(warned) == 1 and warned[0].startswith("warning: results/"), err
    assert len(err) == 1, err


def test_complete_only_says_once_what_it_skipped(lab, tmp_path, capsys):
    code, out, err = _run(["import", lab / "mapping.toml", "-o", tmp_path / "c",
                           "--complete-only"], capsys)
    assert code == 0 and "did not complete" not in out
    assert len(err) == 1 and err[0].startswith("skipped (incomplete): results/"), err


def test_an_error_comes_alone_and_names_the_file_relative_to_the_mapping(
        lab, tmp_path, capsys, monkeypatch):
    text = (lab / "mapping.toml").read_text()
    mapping = lab.parent / "bad_mapping.toml"
    mapping.write_text(text.replace('phase_rad = { axis = "phase", unit = "turn" }',
                                    'phase_rad = { axis = "phase", unit = "V" }')
                       .replace('"results/', '"lab/results/'))
    monkeypatch.chdir(tmp_path)
    code, out, err = _run(["import", mapping, "-o", "c"], capsys)
    assert code == 2 and len(err) == 1, err
    assert err[0].startswith("dpdfit: error: lab/results/"), err[0]
    assert "unit 'V' does not convert to phase_rad" in err[0]
    assert not (tmp_path / "c").exists()


def test_write_artiq_results_then_import_as_the_help_example_does(tmp_path, capsys):
    lab = tmp_path / "lab"
    code, out, err = _run(["write-artiq-results", BUNDLED, lab, "--shape", "ndscan"], capsys)
    assert code == 0 and "mapping.toml" in out and not err
    code, out, err = _run(["import", lab / "mapping.toml", "-o", tmp_path / "c"], capsys)
    assert code == 0 and "wrote campaign" in out and not err
    code, _, err = _run(["write-artiq-results", BUNDLED, lab], capsys)
    assert code == 2 and len(err) == 1 and "exists and is not empty" in err[0]


@pytest.fixture(scope="module")
def rates_in_hz_labelled_khz(tmp_path_factory):
    """Results files whose gate-rate mapping says kHz for values stored in Hz."""
    from dpdfit.simulation.artiq_results import write_ndscan_campaign
    lab = tmp_path_factory.mktemp("rates_lab") / "lab"
    mapping = write_ndscan_campaign(BUNDLED, lab)
    text = mapping.read_text()
    for col, ch in (("xi0_khz", "xi0"), ("xi0_err_khz", "xi0_err")):
        old = f'{col} = {{ channel = "{ch}" }}'
        assert old in text
        text = text.replace(old, f'{col} = {{ channel = "{ch}", unit = "kHz" }}')
    mapping.write_text(text)
    return mapping


@pytest.mark.parametrize("command", [["import", "-o", "OUT"], ["analyze", "-o", "OUT"],
                                     ["diagnose", "--json"]])
def test_rates_a_thousand_times_too_large_are_refused_in_one_line(
        rates_in_hz_labelled_khz, tmp_path, capsys, command):
    from tests.helpers.cli_refusal import assert_refused
    out = tmp_path / "out"
    argv = [command[0], rates_in_hz_labelled_khz] + [out if a == "OUT" else a
                                                     for a in command[1:]]
    line = assert_refused(capsys, argv, ["imported gate_rates (row 1, column 'xi0_khz')",
                                         "gate rate 3349 kHz exceeds the mode frequency "
                                         "1840 kHz", "stored in Hz with unit kHz?"],
                          inputs=[rates_in_hz_labelled_khz])
    assert "(line" not in line and not out.exists()


def test_a_refused_recording_time_names_its_results_file_not_the_staged_folder(
        tmp_path, capsys):
    import h5py
    from tests.helpers.small_artiq_lab import SMALL_MAPPING, write_small_lab
    lab = tmp_path / "lab"
    parity = write_small_lab(lab)[1]
    (lab / "map.toml").write_text(SMALL_MAPPING)
    with h5py.File(parity, "r+") as f:                  # a clock seventy years ahead
        del f["start_time"]
        f["start_time"] = 4e9
    code, out, err = _run(["import", lab / "map.toml", "-o", tmp_path / "c"], capsys)
    assert code == 2 and len(err) == 1, err
    assert err[0].startswith(f"dpdfit: error: {parity.relative_to(lab).as_posix()} (rid 2): its "
                             "start_time is campaign.json's gates_recorded"), err[0]
    assert "lies more than a year after the last calibration run" in err[0]
    assert ".c." not in err[0] and not (tmp_path / "c").exists()
    (lab / "map.toml").write_text(SMALL_MAPPING.replace(
        "nu_hz = 1.84e6", "nu_hz = 1.84e6\ngates_recorded = 2090-01-01T00:00:00Z"))
    code, out, err = _run(["import", lab / "map.toml", "-o", tmp_path / "c"], capsys)
    assert code == 2 and err == [f"dpdfit: error: {lab / 'map.toml'}: [campaign] key "
                                 "'gates_recorded' (2090-01-01T00:00:00+00:00) lies more than "
                                 "a year after the last calibration run "
                                 "(2025-10-09T08:53:20+00:00)"], err
