"""Calibration stability over runs (Supplement S2, Figs. S1-S2): dpdfit.analyses.stability."""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from dpdfit.simulation.aom_truth import ou_series
from dpdfit.errors import DpdfitError, FitError, InputError
from dpdfit.analyses.stability import allan_deviation, drift_test, stability
from dpdfit.report.figure_io import save_figures
from dpdfit.report.stability_plots import stability_figures
from dpdfit.cli.stability import add_stability_command
from tests.helpers.paths import ROOT

CAMPAIGN = ROOT / "datasets" / "synthetic_campaign"
AMP = CAMPAIGN / "calibration_amplitude.csv"
PHASE = CAMPAIGN / "calibration_phase.csv"

REQUIRED_KEYS = {"mean", "std", "relative_std", "n_runs", "span_days", "trend_per_day",
                 "trend_per_day_err"}


@pytest.fixture(scope="module")
def amp_result():
    return stability(AMP, kind="amplitude")


def _run_cli(argv):
    """Parse with a parser holding only the stability sub-command; mimic dpdfit.cli.main.main."""
    p = argparse.ArgumentParser(prog="dpdfit")
    sub = p.add_subparsers(dest="command", required=True)
    add_stability_command(sub)
    args = p.parse_args(argv)
    return args.func(args)


# --------------------------------------------------------------------------- bundled campaign


def test_amplitude_runs_match_truth(amp_result):
    r = amp_result
    truth = json.loads((CAMPAIGN / "truth.json").read_text())["calibration"]["amplitude_runs"]
    true = {t["run"]: t["A_corr"] for t in truth}
    assert r.n_runs == 34 and len(true) == 34
    assert 109 < r.span_days < 111
    pulls = np.array([(x["value"] - true[x["run"]]) / x["stderr"] for x in r.runs])
    assert np.max(np.abs(pulls)) < 4.0
    assert 0.5 < np.mean(pulls ** 2) < 1.7          # stderr honest, chi2/34
    # runs are in time order and days start at 0
    days = r.days
    assert days[0] == 0 and np.all(np.diff(days) >= 0)


def test_amplitude_summary_matches_direct_computation(amp_result):
    r = amp_result
    v = np.array([x["value"] for x in r.runs])
    assert r.mean == pytest.approx(v.mean(), rel=1e-12)
    assert r.std == pytest.approx(np.std(v, ddof=1), rel=1e-12)
    assert r.relative_std == pytest.approx(np.std(v, ddof=1) / abs(v.mean()), rel=1e-12)
    # the paper's numbers (0.5655, 0.0091) within the sampling error of 34 runs
    assert abs(r.mean - 0.5655) < 3 * 0.0091 / np.sqrt(34)
    assert 0.006 < r.std < 0.012
    # envelope: curves of all runs, mean and sd at A = 1 equal the scalar summary
    assert r.curves.shape == (34, r.grid.size)
    assert r.mean_curve[-1] == pytest.approx(r.mean, rel=1e-9)
    assert r.std_curve[-1] == pytest.approx(r.std, rel=1e-9)
    assert r.mean_curve[0] == pytest.approx(0.0, abs=1e-12)
    # the truth has no trend: the drift test should not flag one at this level
    assert r.drift["trend_ci95"][0] < r.trend_per_day < r.drift["trend_ci95"][1]
    assert r.allan and all(n >= 1 for _, _, n in r.allan)


def test_dataframe_input_equals_file_input(amp_result):
    df = pd.read_csv(AMP)
    r2 = stability(df, kind="amplitude")
    assert r2.mean == pytest.approx(amp_result.mean, rel=1e-12)
    assert r2.std == pytest.approx(amp_result.std, rel=1e-12)


def test_json_keys_and_report(amp_result):
    d = amp_result.to_dict()
    assert REQUIRED_KEYS <= set(d)
    assert {"trend_ci95", "trend_p_value", "runs", "allan", "kind"} <= set(d)
    assert set(d["runs"][0]) >= {"run", "timestamp", "value", "stderr"}
    assert set(d["allan"][0]) == {"tau_days", "adev", "n_pairs"}
    json.dumps(d)  # plain Python throughout
    text = amp_result.report()
    assert "34 over" in text and "trend" in text


def test_cli_json(capsys):
    assert _run_cli(["stability", str(AMP), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert REQUIRED_KEYS <= set(d)
    assert d["kind"] == "amplitude" and d["n_runs"] == 34


def test_cli_auto_phase_and_plots(tmp_path, capsys):
    assert _run_cli(["stability", str(PHASE), "--json", "--plot", str(tmp_path)]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["kind"] == "phase" and d["n_runs"] == 6
    assert 2.5 / 24 < d["span_days"] < 3.5 / 24
    for name in ("figS1_stability_phase.png", "figS2_envelope_phase.png"):
        f = tmp_path / name
        assert f.exists() and f.read_bytes()[:4] == b"\x89PNG"
    assert not [p for p in os.listdir(tmp_path) if p.endswith(".part")]


def test_phase_kind():
    r = stability(PHASE, kind="phase", A_min=0.1)
    assert r.n_runs == 6 and r.order == 5
    assert abs(r.mean - 0.2776) < 0.005          # paper: 0.2776 rad
    assert r.std < 0.003                          # paper: 0.0009 rad
    assert r.grid[0] == pytest.approx(0.1)
    assert np.all(np.isfinite(r.stderrs)) and np.all(r.stderrs > 0)


def test_amplitude_plots(amp_result, tmp_path):
    paths = save_figures(stability_figures(amp_result), tmp_path)
    assert [Path(p).name for p in paths] == ["figS1_stability_amplitude.png",
                                             "figS2_envelope_amplitude.png"]
    assert all(Path(p).stat().st_size > 5000 for p in paths)


# --------------------------------------------------------------------------- drift test


def _replicates(nrep, n, trend, s, se_lo, se_hi, seed):
    rng = np.random.default_rng(seed)
    cover = false_pos = 0
    for _ in range(nrep):
        t = np.sort(rng.uniform(0, 110, n))
        se = rng.uniform(se_lo, se_hi, n)
        y = 0.5655 + trend * t + rng.normal(0, s, n) + rng.normal(0, se)
        lo, hi = drift_test(t, y, se)["trend_ci95"]
        cover += lo <= trend <= hi
        y0 = 0.5655 + rng.normal(0, s, n) + rng.normal(0, se)
        false_pos += drift_test(t, y0, se)["trend_p_value"] < 0.05
    return cover / nrep, false_pos / nrep


@pytest.mark.slow
def test_drift_coverage_campaign_like():
    # 34 runs over 110 days, excess scatter ~ 2x the fit errors (as in the campaign)
    cover, fp = _replicates(800, 34, 1e-4, 0.0085, 0.003, 0.005, seed=1)
    assert 0.92 <= cover <= 0.98
    assert 0.025 <= fp <= 0.075


@pytest.mark.slow
def test_drift_coverage_heteroscedastic():
    # fit errors comparable to the excess scatter and very unequal between runs
    cover, fp = _replicates(500, 34, 1e-4, 0.004, 0.001, 0.008, seed=2)
    assert 0.92 <= cover <= 0.98
    assert 0.02 <= fp <= 0.08


def test_drift_detects_a_real_trend():
    rng = np.random.default_rng(5)
    t = np.sort(rng.uniform(0, 110, 34))
    se = np.full(34, 0.004)
    y = 0.56 + 3e-4 * t + rng.normal(0, 0.008, 34) + rng.normal(0, se)
    d = drift_test(t, y, se)
    assert d["trend_p_value"] < 1e-3
    assert d["trend_ci95"][0] < 3e-4 < d["trend_ci95"][1]


def test_drift_equal_errors_is_ols():
    rng = np.random.default_rng(7)
    t = np.sort(rng.uniform(0, 50, 20))
    y = 1 + 0.01 * t + rng.normal(0, 0.1, 20)
    d = drift_test(t, y, np.full(20, 0.01))      # scatter >> fit errors
    X = np.column_stack([np.ones(20), t])
    beta, rss, *_ = np.linalg.lstsq(X, y, rcond=None)
    cov = rss[0] / 18 * np.linalg.inv(X.T @ X)
    assert d["trend_per_day"] == pytest.approx(beta[1], rel=1e-9)
    assert d["trend_per_day_err"] == pytest.approx(np.sqrt(cov[1, 1]), rel=1e-6)


# --------------------------------------------------------------------------- Allan deviation


def test_allan_white_noise_falls_as_inverse_sqrt_tau():
    rng = np.random.default_rng(11)
    t = np.cumsum(rng.exponential(1.0, 4000))     # irregular, mean spacing 1 day
    y = rng.normal(0, 1.0, t.size)
    taus = [4.0, 16.0, 64.0, 256.0]
    res = allan_deviation(t, y, taus=taus)
    assert [r[0] for r in res] == taus
    adev = np.array([r[1] for r in res])
    slope = np.polyfit(np.log(taus), np.log(adev), 1)[0]
    assert -0.6 < slope < -0.4
    # level: sigma * sqrt(<1/N>) with N ~ Poisson(4) runs per window (>= 1/sqrt(4) by Jensen)
    assert 0.45 < adev[0] < 0.65
    assert all(n >= 2 for _, _, n in res)


def test_allan_of_slow_wander_does_not_average_down():
    rng = np.random.default_rng(12)
    t = np.cumsum(rng.exponential(1.0, 3000))
    y = ou_series(t, 1.0, 300.0, rng)            # correlated over ~300 days
    res = allan_deviation(t, y, taus=[4.0, 64.0])
    white_ratio = 0.25                          # 1/sqrt(16)
    assert res[1][1] / res[0][1] > 2 * white_ratio


def test_allan_needs_two_adjacent_windows():
    assert allan_deviation([0.0, 1.0], [1.0, 2.0], taus=[5.0]) == []
    (tau, adev, n), = allan_deviation([0.0, 1.0], [1.0, 2.0], taus=[1.0])
    assert n == 1 and adev == pytest.approx(np.sqrt(0.5))


# --------------------------------------------------------------------------- bad input


def _two_runs(tmp_path, n_b=201, **over):
    df = pd.read_csv(AMP)
    a = df[df["run"] == "R001"]
    b = df[df["run"] == "R002"].iloc[::max(1, 201 // n_b)].head(n_b)
    out = pd.concat([a, b])
    for k, v in over.items():
        out[k] = v
    return out


def test_single_run_refused(tmp_path):
    df = pd.read_csv(AMP)
    f = tmp_path / "one.csv"
    df[df["run"] == "R001"].to_csv(f, index=False)
    with pytest.raises(InputError, match=r"needs >= 2 calibration runs, the file holds 1") as e:
        stability(f)
    assert str(f) in str(e.value) and "\n" not in str(e.value)


def test_missing_run_and_timestamp_columns(tmp_path):
    df = _two_runs(tmp_path)
    f = tmp_path / "norun.csv"
    df.drop(columns=["run"]).to_csv(f, index=False)
    with pytest.raises(InputError, match="needs a 'run' column"):
        stability(f)
    g = tmp_path / "nots.csv"
    df.drop(columns=["timestamp"]).to_csv(g, index=False)
    with pytest.raises(InputError, match="needs a 'timestamp' column"):
        stability(g)


def test_bad_and_empty_timestamps(tmp_path):
    df = _two_runs(tmp_path)
    df.iloc[5, df.columns.get_loc("timestamp")] = "yesterday"
    f = tmp_path / "badts.csv"
    df.to_csv(f, index=False)
    with pytest.raises(InputError, match=r"column 'timestamp', row 6: 'yesterday' is not a date"):
        stability(f)
    df.iloc[5, df.columns.get_loc("timestamp")] = ""
    df.to_csv(f, index=False)
    with pytest.raises(InputError, match="column 'timestamp', row 6"):
        stability(f)
    with pytest.raises(InputError, match="timestamp"):
        stability(df)                             # DataFrame path too


def test_run_with_too_few_points(tmp_path):
    df = _two_runs(tmp_path, n_b=5)
    f = tmp_path / "short.csv"
    df.to_csv(f, index=False)
    with pytest.raises(FitError, match=r"run 'R002' \(5 points\)") as e:
        stability(f, order=8)
    assert str(f) in str(e.value) and "\n" not in str(e.value)


def test_cli_bad_input_raises_dpdfit_error(tmp_path):
    df = pd.read_csv(AMP)
    f = tmp_path / "one.csv"
    df[df["run"] == "R003"].to_csv(f, index=False)
    with pytest.raises(DpdfitError, match="the file holds 1"):
        _run_cli(["stability", str(f)])
