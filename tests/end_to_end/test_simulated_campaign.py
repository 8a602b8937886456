"""Campaign simulator (small configuration) and the `analyze` main job."""

import dataclasses
import json
import shutil

import numpy as np
import pandas as pd
import pytest

from dpdfit.pipeline.analyze import analyze
from dpdfit.simulation.campaign import CampaignConfig, campaign_hashes, parse_effects, simulate_campaign
from dpdfit.cli.main import main
from dpdfit.errors import InputError

SMALL = CampaignConfig(n_amp_runs=4, n_phase_runs=2, cal_points=101,
                       trace_amplitudes=(0.2, 0.35, 0.5), n_samples=2 ** 19,
                       bundled_traces=((0.5, 0),))


def quiet(label, total):
    from dpdfit.core.progress import progress_bar
    return progress_bar(total=total, desc=label, disable=True)


@pytest.fixture(scope="module")
def small_campaign(tmp_path_factory):
    out = tmp_path_factory.mktemp("c") / "camp"
    simulate_campaign(out, config=SMALL, progress=quiet, include_gates=False)
    return out


def test_parse_effects():
    assert parse_effects("aom_memory=50, spam_offset=0.002") == {"aom_memory": 50.0,
                                                                  "spam_offset": 0.002}
    assert parse_effects(None) == {}
    with pytest.raises(InputError, match="unknown effect 'nope'"):
        parse_effects("nope=1")
    with pytest.raises(InputError, match="NAME=STRENGTH"):
        parse_effects("aom_memory")
    assert parse_effects("aom_memory=60,aom_memory.f_off=2") == {"aom_memory": 60.0,
                                                                  "aom_memory.f_off": 2.0}
    with pytest.raises(InputError, match="has no parameter 'nope'"):
        parse_effects("aom_memory.nope=1")
    # the simulator's former knobs without a catalog effect are refused as effects
    for name in ("aom_memory_offset", "calibration_drift"):
        with pytest.raises(InputError, match=f"unknown effect '{name}'"):
            parse_effects(f"{name}=1")


def test_layout_and_determinism(small_campaign, tmp_path):
    files = {p.name for p in small_campaign.iterdir()}
    assert {"campaign.json", "calibration_amplitude.csv", "calibration_phase.csv", "spectra.csv",
            "traces.csv", "traces", "README.md", "truth.json"} <= files
    amp = pd.read_csv(small_campaign / "calibration_amplitude.csv")
    assert list(amp.columns) == ["run", "timestamp", "A", "power", "power_err"]
    assert amp["run"].nunique() == 4
    sp = pd.read_csv(small_campaign / "spectra.csv")
    assert {"A", "dpd", "sideband", "n", "P_dB"} <= set(sp.columns)
    assert set(sp["sideband"]) == {"red", "blue"} and set(sp["dpd"]) == {0, 1}
    idx = pd.read_csv(small_campaign / "traces.csv")
    assert list(idx.columns[:7]) == ["file", "A", "dpd", "fs", "fdet", "nu", "xi0"]
    again = tmp_path / "again"
    simulate_campaign(again, config=SMALL, progress=quiet, include_gates=False)
    assert campaign_hashes(again) == campaign_hashes(small_campaign)
    other = tmp_path / "other"
    simulate_campaign(other, config=CampaignConfig(**{**SMALL.__dict__, "seed": 7}),
                      progress=quiet, include_gates=False)
    assert campaign_hashes(other)["spectra.csv"] != campaign_hashes(small_campaign)["spectra.csv"]


def test_refuses_non_empty_output(small_campaign):
    with pytest.raises(InputError, match="exists and is not empty"):
        simulate_campaign(small_campaign, config=SMALL, progress=quiet, include_gates=False)


@pytest.mark.slow
def test_analyze_runs_everything_present(small_campaign, tmp_path):
    out = tmp_path / "res"
    s = analyze(small_campaign, out, plots=False, diagnosis=False).summary
    st = {k: v["status"] for k, v in s["analyses"].items()}
    assert st == {"calibration": "ok", "stability": "ok", "sweep": "ok", "spectra": "ok",
                  "traces": "ok", "gates": "skipped", "propagation": "ok", "budget": "ok",
                  "diagnosis": "skipped"}
    for f in ("summary.md", "summary.json", "calibration.json", "sweep.csv",
              "spectra_measured.csv", "traces_check.csv", "calibration_runs.csv"):
        assert (out / f).exists(), f
    # the raw trace reproduces the spectra table (stored with 10 significant digits)
    assert s["traces"]["max_abs_difference_to_spectra_csv_dB"] < 1e-6
    assert not list(out.glob(".*part"))


def test_analyze_missing_and_malformed_files(small_campaign, tmp_path, capsys):
    camp = tmp_path / "camp"
    shutil.copytree(small_campaign, camp)
    (camp / "traces.csv").unlink()
    sp = (camp / "spectra.csv").read_text().splitlines()
    cells = sp[5].split(",")
    cells[4] = "oops"
    sp[5] = ",".join(cells)
    (camp / "spectra.csv").write_text("\n".join(sp) + "\n")
    out = tmp_path / "res"
    out.mkdir()
    (out / "summary.json").write_text("old")
    code = main(["analyze", str(camp), "-o", str(out), "--no-plots", "--no-diagnosis"])
    captured = capsys.readouterr()
    assert code == 2
    assert "spectra.csv, column 'P_dB', row 5: 'oops' is not a number" in captured.err
    s = json.loads((out / "summary.json").read_text())
    assert s["analyses"]["traces"]["status"] == "skipped"
    assert "traces.csv not found" in s["analyses"]["traces"]["detail"]
    assert s["analyses"]["spectra"]["status"] == "failed"
    assert s["analyses"]["calibration"]["status"] == "ok"
    assert s["analyses"]["sweep"]["status"] == "ok"


def test_analyze_missing_folder(tmp_path, capsys):
    code = main(["analyze", str(tmp_path / "nope"), "-o", str(tmp_path / "r")])
    assert code == 2 and "campaign folder not found" in capsys.readouterr().err


def test_trace_regenerates_from_its_seed(small_campaign):
    from dpdfit.simulation.campaign import regenerate_trace
    idx = pd.read_csv(small_campaign / "traces.csv")
    row = idx.iloc[0]
    with np.load(small_campaign / row["file"]) as z:
        q, scale = z["trace"], float(z["scale"])
    q2, scale2 = regenerate_trace(row["seed"], config=SMALL)
    assert np.array_equal(q, q2) and scale == scale2
    with pytest.raises(InputError, match="is not '<seed>:4:<index>:<dpd>'"):
        regenerate_trace("garbage")


def test_effects_change_the_recordings(tmp_path):
    base = CampaignConfig(**{**SMALL.__dict__, "trace_amplitudes": (0.5,), "bundled_traces": ()})
    a, b = tmp_path / "a", tmp_path / "b"
    simulate_campaign(a, config=base, progress=quiet, include_gates=False)
    simulate_campaign(b, config=base, effects={"aom_memory": 40, "aom_memory.f_off": 30},
                      progress=quiet, include_gates=False)
    sa, sb = (pd.read_csv(p / "spectra.csv") for p in (a, b))
    ia = sa.set_index(["dpd", "sideband", "n"])["P_dB"]
    ib = sb.set_index(["dpd", "sideband", "n"])["P_dB"]
    # memory with an offset centre: red and blue gate tones no longer equal
    asym = abs(ib[(0, "red", 1)] - ib[(0, "blue", 1)])
    assert asym > 0.5 and abs(ia[(0, "red", 1)] - ia[(0, "blue", 1)]) < 0.1
    truth = json.loads((b / "truth.json").read_text())
    # injected through the registry (the effect's own hooks), recorded as such
    memory = dict(dict(truth["config"]["injected"])["aom_memory"])
    assert memory["tau"] == 40.0 and memory["f_off"] == 30.0
    assert truth["config"]["effects"] == {"aom_memory": 40.0, "aom_memory.f_off": 30.0}


@pytest.mark.slow
def test_gate_power_offset_reaches_the_time_scans(tmp_path):
    """A time scan is a gate run: the systematic power offset acts on it too.

    The harness campaign with one gate setting (at the time scan's amplitude) instead of
    three: the time scans, the only gate recordings checked, keep their amplitude, points
    and shots, and the spectra are the harness campaign's; a third of the engine runs."""
    from dpdfit.simulation.harness import harness_config
    full = harness_config(11)
    cfg = dataclasses.replace(full, gate_amplitudes=(full.time_scan_A,),
                              scan_shots=full.scan_shots[:1])
    a, b = tmp_path / "a", tmp_path / "b"
    simulate_campaign(a, config=cfg, progress=quiet)
    simulate_campaign(b, config=cfg, effects={"gate_rate_miscalibration": 0.4}, progress=quiet)
    ta, tb = (pd.read_csv(p / "time_scans.csv") for p in (a, b))
    late = ta.t_us > ta.t_us.max() / 2
    # same seed, same draws: only the probabilities differ, and only where the gate acts
    start = ta.t_us == 0
    assert (ta.loc[start, "n00"] == tb.loc[start, "n00"]).all()
    assert (ta.loc[late, ["n00", "n11"]] != tb.loc[late, ["n00", "n11"]]).any(axis=None)
    assert (a / "spectra.csv").read_bytes() == (b / "spectra.csv").read_bytes()


@pytest.mark.slow
def test_analyze_text_in_spectra_amplitude_with_traces_present(small_campaign, tmp_path, capsys):
    """Text in spectra.csv's A column: the spectra step fails with the one line; the
    traces check (which reads the file as recorded) runs on, no traceback."""
    camp = tmp_path / "camp"
    shutil.copytree(small_campaign, camp)
    sp = (camp / "spectra.csv").read_text().splitlines()
    cells = sp[5].split(",")
    cells[0] = "abc"
    sp[5] = ",".join(cells)
    (camp / "spectra.csv").write_text("\n".join(sp) + "\n")
    out = tmp_path / "res"
    code = main(["analyze", str(camp), "-o", str(out), "--no-plots", "--no-diagnosis"])
    captured = capsys.readouterr()
    assert code == 2
    assert "Traceback" not in captured.err
    assert "spectra.csv, column 'A', row 5: 'abc' is not a number" in captured.err
    s = json.loads((out / "summary.json").read_text())
    assert s["analyses"]["spectra"]["status"] == "failed"
    assert s["analyses"]["traces"]["status"] == "ok"


@pytest.mark.slow
def test_analyze_rerun_clears_what_the_previous_run_wrote(small_campaign, tmp_path):
    """A rerun into a used results folder: the old spectra tables go when spectra are skipped."""
    out = tmp_path / "res"
    analyze(small_campaign, out, plots=False, diagnosis=False)
    assert (out / "spectra_measured.csv").exists() and (out / "traces_check.csv").exists()
    (out / "my_notes.txt").write_text("kept")
    camp = tmp_path / "camp"
    shutil.copytree(small_campaign, camp)
    (camp / "spectra.csv").unlink()
    (camp / "traces.csv").unlink()
    s = analyze(camp, out, plots=False, diagnosis=False).summary
    assert s["analyses"]["spectra"]["status"] == "skipped"
    assert not (out / "spectra_measured.csv").exists()
    assert not (out / "traces_check.csv").exists()
    assert (out / "my_notes.txt").read_text() == "kept"
    written = json.loads((out / "summary.json").read_text())["outputs"]
    assert sorted(p.name for p in out.iterdir() if p.name != "my_notes.txt") == sorted(written)


@pytest.fixture(scope="module")
def repeated_campaign(tmp_path_factory):
    """SMALL with 0.5 (a bundled amplitude) and 0.2 recorded once more, after the grid."""
    out = tmp_path_factory.mktemp("c") / "repeated"
    cfg = CampaignConfig(**{**SMALL.__dict__,
                            "trace_amplitudes": SMALL.trace_amplitudes + (0.5, 0.2)})
    simulate_campaign(out, config=cfg, progress=quiet, include_gates=False)
    return out


def test_a_repeated_amplitude_is_recorded_again_as_repeated_rows(small_campaign,
                                                                 repeated_campaign):
    for name in ("calibration_amplitude.csv", "calibration_phase.csv", "traces.csv",
                 "traces/trace_A0.500_dpd0.npz"):
        assert (repeated_campaign / name).read_bytes() == (small_campaign / name).read_bytes()
    assert sorted(p.name for p in (repeated_campaign / "traces").iterdir()) == \
        sorted(p.name for p in (small_campaign / "traces").iterdir())
    old = (small_campaign / "spectra.csv").read_text()
    new = (repeated_campaign / "spectra.csv").read_text()
    assert new.startswith(old)                   # every earlier recording drawn as before
    sp0 = pd.read_csv(small_campaign / "spectra.csv")
    sp = pd.read_csv(repeated_campaign / "spectra.csv")
    added = sp.iloc[len(sp0):].reset_index(drop=True)
    per = 2 * 2 * len(SMALL.spectra_harmonics)
    assert len(added) == 2 * per and list(added.A.unique()) == [0.5, 0.2]
    # the same tones again, in the same order, each trace from its own stream
    key = ["A", "dpd", "sideband", "n"]
    first = pd.concat([sp0[sp0.A == 0.5], sp0[sp0.A == 0.2]]).reset_index(drop=True)
    assert (added[key] == first[key]).all(axis=None)
    assert (added.P_dB != first.P_dB).all()
    gate = added.n.isin([1, 2])
    assert np.abs(added.P_dB - first.P_dB)[gate].max() < 2.0    # the same tones, jittered


@pytest.mark.slow
def test_analyze_pools_repeated_spectra_and_checks_each_trace_against_its_repeat(
        repeated_campaign, tmp_path):
    out = tmp_path / "res"
    s = analyze(repeated_campaign, out, plots=False, diagnosis=False).summary
    assert s["analyses"]["spectra"]["status"] == "ok"
    m = pd.read_csv(out / "spectra_measured.csv")
    raw = pd.read_csv(repeated_campaign / "spectra.csv")
    assert len(m) == 3 * 2 * 3                   # (A, dpd) x (red, blue, mean), one each
    for (A, d, sb), g in raw[raw.n == 1].groupby(["A", "dpd", "sideband"]):
        row = m[(m.A == A) & (m.dpd == d) & (m.sideband == sb)].iloc[0]
        pooled = 10 * np.log10(np.mean(10 ** (g.P_dB.to_numpy() / 10)))
        assert row["P1_dB"] == pytest.approx(pooled, abs=1e-7)      # written to 10 digits
        assert len(g) == (2 if A in (0.5, 0.2) else 1)
    chk = pd.read_csv(out / "traces_check.csv")
    # the bundled trace is the first recording at 0.5: checked against repeat 1's rows
    assert set(chk["repeat"].astype(str)) == {"1"}
    assert s["traces"]["max_abs_difference_to_spectra_csv_dB"] < 1e-6
