"""The amplitude sweep, efficiency, thresholds, and the spectral CLI commands."""

import json

import numpy as np
import pandas as pd
import pytest

from dpdfit.errors import InputError
from dpdfit.analyses.sweep import COLUMNS, SweepConfig, eta_bar, parse_amplitudes, run_sweep
from dpdfit.analyses.sweep import first_crossing as _first_crossing
from dpdfit.models.waveforms import cardioid, sample_grid, synthesize
from dpdfit.simulation.aom_truth import truth_poly_tf
from tests.helpers.cli_refusal import assert_refused
from tests.helpers.cli_run import run


@pytest.fixture(scope="module")
def sweep_df():
    return run_sweep(truth_poly_tf(), SweepConfig(amplitudes=np.linspace(0.1, 1.0, 19)))


def test_table_layout(sweep_df):
    df = sweep_df
    assert list(df.columns) == COLUMNS
    assert len(df) == 19 * 2 * 3
    assert set(df["sideband"]) == {"red", "blue", "mean"} and set(df["dpd"]) == {0, 1}
    assert np.all(np.isfinite(df[COLUMNS[3:]].to_numpy(dtype=float)))
    m = df[df.sideband == "mean"]
    r, b = df[df.sideband == "red"], df[df.sideband == "blue"]
    assert np.allclose(m["P1_dB"].to_numpy(), 0.5 * (r["P1_dB"].to_numpy() + b["P1_dB"].to_numpy()))
    assert np.allclose(m["R10_dB"], m["P1_dB"] - m["P0_dB"])
    assert np.allclose(m["eps_est"], 1 - m["F_est"])


def test_anchor_and_dP(sweep_df):
    df = sweep_df
    a = df[(np.isclose(df.A, 0.4)) & (df.dpd == 0)]
    assert np.allclose(a["r_rel"], 1.0, atol=1e-12)
    for sb in ("red", "blue"):
        d1 = df[(df.dpd == 1) & (df.sideband == sb)].set_index("A")
        d0 = df[(df.dpd == 0) & (df.sideband == sb)].set_index("A")
        assert np.allclose(d1["dP1_dB"], d1["P1_dB"] - d0["P1_dB"])
        assert np.allclose(d0["dP1_dB"], d1["dP1_dB"])


def test_physics_of_dpd(sweep_df):
    """Below A_corr DPD raises R10 and recovers gate power; efficiency grows with A."""
    m = sweep_df[sweep_df.sideband == "mean"]
    d1, d0 = m[m.dpd == 1].set_index("A"), m[m.dpd == 0].set_index("A")
    Ac = sweep_df.attrs["A_corr"]
    low = d1.index[(d1.index > 0.2) & (d1.index < Ac - 0.05)]
    assert np.all(d1.loc[low, "R10_dB"] > d0.loc[low, "R10_dB"] + 2)
    assert np.all(d1.loc[low, "dP1_dB"] > 0)
    assert np.all(np.diff(d0["eta_bar"].to_numpy()) > 0)
    eta = sweep_df.attrs["eta_corr"]
    assert eta["dpd"] > eta["no_dpd"] > 0


def test_eta_bar_definition():
    tf = truth_poly_tf()
    tones = cardioid()
    grid = sample_grid(1.84e6, 20e3, tones)
    w = synthesize(tones, grid, 1.0)
    # eta_bar = eta_ref <|f_AM(w)|^2> / f_AM(1)^2 ; a constant full drive gives eta_ref
    assert eta_bar(np.ones(10), tf, 0.8) == pytest.approx(0.8)
    assert eta_bar(w, tf, 0.8) == pytest.approx(0.8 * np.mean(tf.f_am(w) ** 2) / tf.A_corr ** 2)


def test_first_crossing_is_exact_for_power_laws():
    x = np.geomspace(0.01, 0.5, 30)
    y = 3e-2 * (x / 0.1) ** 2.5
    for lev in (1e-2, 1e-3, 1e-4):
        expect = 0.1 * (lev / 3e-2) ** (1 / 2.5)
        assert _first_crossing(x, y, lev) == pytest.approx(expect, rel=1e-12)
    assert _first_crossing(x, y, 10.0) is None         # never reached
    assert _first_crossing(x, y, 1e-9) is None         # already above at the start


def test_parse_amplitudes():
    assert np.allclose(parse_amplitudes("0.05:1:100"), np.linspace(0.05, 1, 100))
    for bad in ("0:1.2:10", "0.5:0.2:10", "0:1", "a:b:c", "0:1:1"):
        with pytest.raises(InputError):
            parse_amplitudes(bad)


# ------------------------------------------------------------- CLI

def test_sweep_and_thresholds_cli(bundled_calibration_files, tmp_path, capsys):
    amp, ph = bundled_calibration_files
    cal = tmp_path / "cal.json"
    assert run(["calibrate", "--amplitude", amp, "--phase", ph, "-o", cal], capsys)[0] == 0
    out = tmp_path / "sweep.csv"
    code, stdout, err = run(["sweep", cal, "--amplitudes", "0.05:1:40", "-o", out,
                             "--plot", tmp_path / "figs"], capsys)
    assert code == 0, err
    df = pd.read_csv(out, comment="#")
    assert list(df.columns) == COLUMNS and len(df) == 240 and set(df["dpd"]) == {0, 1}
    for name in ("fig2_spectral.png", "figS5_spectral.png", "fig5_eps_vs_eta.png",
                 "figS3_phase_space.png"):
        assert (tmp_path / "figs" / name).read_bytes()[:4] == b"\x89PNG"
    code, stdout, err = run(["thresholds", out, "--json"], capsys)
    assert code == 0, err
    th = json.loads(stdout)
    assert set(th) == {"eta_corr", "eta_th"}
    assert set(th["eta_corr"]) == {"dpd", "no_dpd"}
    assert set(th["eta_th"]["dpd"]) == {"1e-2", "1e-3", "1e-4"}
    assert th["eta_th"]["dpd"]["1e-3"] > th["eta_th"]["no_dpd"]["1e-3"]


def test_estimate_cli_keys(capsys):
    code, out, err = run(["estimate", "--powers-db", "0:-40,1:0,2:0,3:-30", "--json"], capsys)
    assert code == 0, err
    d = json.loads(out)
    for k in ("F_est", "eps_est", "F", "G", "Phi"):
        assert isinstance(d[k], float)
    assert d["eps_est"] == pytest.approx(1 - d["F_est"])
    code, out2, _ = run(["estimate", "--powers-db", "0:-40,1:0,2:0,3:-30", "--json",
                         "--formula", "paper"], capsys)
    assert json.loads(out2)["eps_est"] == pytest.approx(2 * d["eps_est"], rel=0.01)


def test_im_table_cli(capsys):
    code, out, err = run(["im-table", "--json"], capsys)
    assert code == 0, err
    d = json.loads(out)
    assert set(d) == {"0", "3"} and set(d["0"]) == {"1e-2", "1e-3", "1e-4"}
    code, out, err = run(["im-table", "--json", "--as-printed"], capsys)
    assert json.loads(out)["0"]["1e-3"] == pytest.approx(40.3, abs=0.05)


@pytest.mark.parametrize("argv, needle", [
    (["estimate", "--powers-db", "0:-40,1:0,3:-30"], "gate tone n=2 is missing"),
    (["estimate", "--powers-db", "0=-40,1:0,2:0"], "'0=-40' is not 'n:dB'"),
    (["estimate", "--powers-db", "0:-40,1:0,2:nan"], "finite"),
    (["estimate", "--powers-db", "1:0,2:0", "--nbar", "-1"], "option --nbar: must be >= 0"),
])
def test_estimate_bad_input(tmp_path, capsys, argv, needle):
    assert_refused(capsys, argv, [needle], no_partial_output_in=tmp_path)


def test_sweep_bad_input(bundled_calibration_files, tmp_path, capsys):
    amp, ph = bundled_calibration_files
    cal = tmp_path / "cal.json"
    assert run(["calibrate", "--amplitude", amp, "-o", cal], capsys)[0] == 0
    before = set(tmp_path.iterdir())
    for argv, needle in [
        (["--amplitudes", "0:1.5:10"], "0 <= START < STOP <= 1"),
        (["--xi0", "5.6e3", "--nu", "1.8400001e6"], "not a ratio of integers"),
        (["--xi0", "-1"], "option --xi0: must be > 0"),
    ]:
        code, out, err = run(["sweep", cal, "-o", tmp_path / "s.csv"] + argv, capsys)
        assert code == 2 and needle in err and len(err.strip().splitlines()) == 1, err
    assert set(tmp_path.iterdir()) == before          # no partial outputs


def test_thresholds_bad_file(tmp_path, capsys):
    p = tmp_path / "s.csv"
    p.write_text("A,dpd\n0.1,0\n")
    assert_refused(capsys, ["thresholds", p], ["required column is missing"], [p],
                   no_partial_output_in=tmp_path)
