"""Posterior sampling of the amplitude transfer function and drift propagation."""

import argparse
import json

import numpy as np
import pandas as pd
import pytest

from dpdfit.simulation.aom_truth import BraggAOM, PhotodiodeNoise, simulate_amplitude_run
from dpdfit.fits.calibration import Calibration, fit_amplitude, fit_phase
from dpdfit.errors import DpdfitError
from dpdfit.fits.posterior import ConvergenceError, PosteriorResult, sample_amplitude_posterior
from dpdfit.fits.drift import drift_model
from dpdfit.analyses.propagation import propagate, recalibration
from dpdfit.report.figure_io import save_figures
from dpdfit.report.posterior_plots import corner_figure
from dpdfit.cli.propagate import add_propagate_command
from dpdfit.analyses.sweep import SweepConfig, run_sweep
from dpdfit.models.transfer import TransferFunction

A_GRID = np.linspace(0.0, 1.0, 201)
KEYS = ["F_est_median", "F_est_q16", "F_est_q84", "F_est_q2.5", "F_est_q97.5"]


def _run(seed, aom=BraggAOM()):
    return simulate_amplitude_run(aom, A_GRID, np.random.default_rng(seed), PhotodiodeNoise())


def _runs_frame(n_runs=4, seed=5, bad_run=None):
    rng = np.random.default_rng(seed)
    frames = []
    t0 = pd.Timestamp("2026-01-01T09:00:00Z")
    for k in range(n_runs):
        aom = BraggAOM(A_corr=0.5655 + 0.009 * rng.standard_normal())
        df = simulate_amplitude_run(aom, A_GRID, rng)
        if bad_run == k:
            df = df.iloc[:5]
        df.insert(0, "timestamp", (t0 + pd.Timedelta(days=3 * k)).isoformat())
        df.insert(0, "run", f"R{k + 1:03d}")
        frames.append(df)
    return pd.concat(frames, ignore_index=True)


@pytest.fixture(scope="module")
def posterior():
    df = _run(11)
    return sample_amplitude_posterior(df["A"], df["power"], df["power_err"], 8,
                                      n_walkers=32, n_steps=300, seed=3)


def test_posterior_result_structure(posterior, tmp_path):
    r = posterior
    assert isinstance(r, PosteriorResult) and r.converged
    assert r.a_draws.shape == (32 * 240, 8) and np.all(r.a_draws[:, 0] == 1.0)
    assert np.allclose(r.A_corr_draws, r.a_draws.sum(axis=1))
    assert r.tau.shape == (9,) and np.all(np.isfinite(r.tau))
    assert (r.n_steps - r.n_discard) >= 50 * r.tau_max
    assert 0.3 < r.acceptance <= 1.0
    assert r.n_independent == pytest.approx(32 * 240 / r.tau_max)
    # posterior agrees with the least-squares fit (nearly Gaussian problem)
    s = r.A_corr_summary()
    assert abs(s["median"] - r.fit.A_corr) < 0.2 * r.fit.A_corr_stderr
    assert (s["q84"] - s["q16"]) / 2 == pytest.approx(r.fit.A_corr_stderr, rel=0.1)
    d = json.loads(json.dumps(r.to_dict()))
    assert set(d["A_corr"]) == {"median", "q16", "q84", "q2.5", "q97.5"}
    assert "K = 8" in r.report() and "independent samples" in r.report()
    with pytest.raises(Exception):
        r.a_draws[0, 0] = 2.0
    out = save_figures({"corner": corner_figure(r)}, tmp_path)
    assert (tmp_path / "corner.png").stat().st_size > 1000 and out[0].endswith("corner.png")


def test_noise_parameter_without_power_err():
    df = _run(12)
    r = sample_amplitude_posterior(df["A"], df["power"], None, 8, n_walkers=32, n_steps=250,
                                   seed=1)
    assert r.sigma_draws is not None and r.tau.shape == (10,)
    assert r.converged and np.all(np.isfinite(r.A_corr_draws))
    # the common sigma lies within the range of the heteroscedastic truth
    assert 5e-4 < np.median(r.sigma_draws) < 2.5e-3


def test_refuses_short_chain():
    df = _run(13)
    with pytest.raises(ConvergenceError, match="autocorrelation times"):
        sample_amplitude_posterior(df["A"], df["power"], df["power_err"], 8, n_walkers=18,
                                   n_steps=40, seed=0)
    # plain stretch moves in 8 dimensions need far longer chains
    with pytest.raises(ConvergenceError):
        sample_amplitude_posterior(df["A"], df["power"], df["power_err"], 8, n_walkers=18,
                                   n_steps=300, seed=0, moves="stretch")
    r = sample_amplitude_posterior(df["A"], df["power"], df["power_err"], 8, n_walkers=18,
                                   n_steps=40, seed=0, force=True)
    assert not r.converged and "NOT CONVERGED" in r.report()
    assert isinstance(ConvergenceError("x"), DpdfitError)


@pytest.mark.slow
def test_credible_interval_coverage():
    """68 % and 95 % intervals of A_corr cover the truth at their nominal rates (+/- 3 %).

    400 replicates of a 201-point run of the physical Bragg AOM with the default
    photodiode noise; every chain (18 walkers x 200 steps) passes the
    convergence policy (no force).
    """
    aom = BraggAOM()
    truth = aom.true_A_corr
    n = 400
    hit68 = hit95 = 0
    for i in range(n):
        df = _run(10_000 + i, aom)
        r = sample_amplitude_posterior(df["A"].to_numpy(), df["power"].to_numpy(),
                                       df["power_err"].to_numpy(), 8, n_walkers=18,
                                       n_steps=200, seed=i)
        lo, hi = r.interval(0.68)
        hit68 += lo <= truth <= hi
        lo, hi = r.interval(0.95)
        hit95 += lo <= truth <= hi
    assert abs(hit68 / n - 0.68) <= 0.03, hit68 / n
    assert abs(hit95 / n - 0.95) <= 0.03, hit95 / n


def test_drift_model_and_perturbation():
    df = _runs_frame(6, seed=2)
    dm = drift_model(df)
    assert len(dm.runs) == 6 and dm.days[-1] == pytest.approx(15.0)
    assert dm.sigma(0) == 0.0
    assert dm.sigma(1e6) == pytest.approx(np.sqrt(2) * dm.sigma_drift)
    assert dm.sigma(1.0) <= dm.sigma(10.0) + 1e-15
    assert 0 < dm.sigma_drift < 0.05
    # the predictive draws move y(1) by the drift and keep a_1 = 1
    post = sample_amplitude_posterior(df.loc[df.run == "R006", "A"],
                                      df.loc[df.run == "R006", "power"],
                                      df.loc[df.run == "R006", "power_err"], 8,
                                      n_walkers=32, n_steps=200, seed=0, drift_sigma=0.01)
    assert np.all(post.a_draws[:, 0] == 1.0)
    assert np.std(post.A_corr_draws) > 0.009


def test_bad_runs_one_line():
    with pytest.raises(DpdfitError, match="run 'R002'.*distinct amplitudes"):
        drift_model(_runs_frame(3, bad_run=1))
    df = _runs_frame(3)
    df.loc[df.index[7], "timestamp"] = "yesterday-ish"
    with pytest.raises(DpdfitError, match="timestamp.*row 8"):
        drift_model(df)
    with pytest.raises(DpdfitError, match="at least 2 calibration runs"):
        drift_model(_runs_frame(1))


def test_propagation_shapes_and_point_estimate(posterior):
    p = propagate(posterior, 0.5, draws=3000, seed=0)
    d = p.to_dict()
    for flag in ("dpd", "no_dpd"):
        assert all(k in d[flag] for k in KEYS)
        assert all(k in d[flag] for k in ("R10_dB_median", "eta_bar_q16", "F_est_point"))
        assert p.samples[flag]["F_est"].shape == (3000,)
        r = d[flag]
        assert r["F_est_q2.5"] <= r["F_est_q16"] <= r["F_est_median"] <= r["F_est_q84"] \
            <= r["F_est_q97.5"]
    assert d["tau"] == posterior.tau_max and d["n_independent"] == posterior.n_independent
    # stale_days = 0 with DPD: the distribution is centred on the point estimate
    assert abs(d["dpd"]["F_est_median"] - d["dpd"]["F_est_point"]) < 1e-6
    assert d["dpd"]["F_est_median"] > d["no_dpd"]["F_est_median"]
    json.dumps(d)
    with pytest.raises(DpdfitError, match="drift model"):
        propagate(posterior, 0.5, stale_days=2, draws=10)


def test_forward_model_matches_sweep():
    """The draw-batched forward model equals run_sweep for the calibration itself."""
    df = _run(21)
    fit = fit_amplitude(df["A"], df["power"], df["power_err"], 8)
    aom = BraggAOM()
    ph = fit_phase(A_GRID, aom.phase(A_GRID), np.full(A_GRID.size, 1e-3), 5)
    post = sample_amplitude_posterior(df["A"], df["power"], df["power_err"], 8,
                                      n_walkers=32, n_steps=150, seed=0, fit=fit)
    p = propagate(post, 0.6, draws=10, phase=ph, seed=0)
    sw = run_sweep(TransferFunction.from_calibration(Calibration(fit, ph)),
                   SweepConfig(amplitudes=np.array([0.2, 0.4, 0.6, 0.8])))
    for flag, d in (("dpd", 1), ("no_dpd", 0)):
        row = sw[(sw.A == 0.6) & (sw.dpd == d) & (sw.sideband == "mean")].iloc[0]
        assert p.point[flag]["F_est"] == pytest.approx(row.F_est, abs=1e-12)
        assert p.point[flag]["eta_bar"] == pytest.approx(row.eta_bar, abs=1e-12)
        assert p.point[flag]["R10_dB"] == pytest.approx(row.R10_dB, abs=1e-6)


def test_propagate_from_runs_with_drift_and_recalibration():
    df = _runs_frame(4, seed=8)
    p0 = propagate(df, 0.5, stale_days=0, draws=2000, seed=1, n_walkers=32, n_steps=200)
    p9 = propagate(df, 0.5, stale_days=9, draws=2000, seed=1, n_walkers=32, n_steps=200,
                   recalibration_loss=1e-4)
    w0 = np.ptp(np.quantile(p0.samples["no_dpd"]["eta_bar"], [0.16, 0.84]))
    w9 = np.ptp(np.quantile(p9.samples["no_dpd"]["eta_bar"], [0.16, 0.84]))
    assert p9.sigma_drift > 0 and w9 > w0
    rc = p9.recalibration
    assert rc["delta_y1"] is not None and abs(rc["delta_y1"]) > 0
    fit = fit_amplitude(*(df.loc[df.run == "R004", c] for c in ("A", "power", "power_err")))
    again = recalibration(fit, 0.5, 1e-4)
    assert again["delta_y1"] == pytest.approx(rc["delta_y1"], rel=1e-6)


def _parser():
    p = argparse.ArgumentParser(prog="dpdfit")
    sub = p.add_subparsers(dest="command", required=True)
    add_propagate_command(sub)
    return p


def test_cli(tmp_path, capsys):
    path = tmp_path / "runs.csv"
    _runs_frame(3, seed=4).to_csv(path, index=False)
    args = _parser().parse_args(["propagate", "--calibration-runs", str(path), "--A", "0.5",
                                 "--stale-days", "2", "--draws", "2000", "--json"])
    assert args.func(args) == 0
    d = json.loads(capsys.readouterr().out)
    assert set(d) >= {"dpd", "no_dpd", "tau", "n_independent", "recalibration"}
    for flag in ("dpd", "no_dpd"):
        assert all(isinstance(d[flag][k], float) for k in KEYS)
    args = _parser().parse_args(["propagate", "--calibration-runs", str(path), "--A", "0.5",
                                 "--draws", "500"])
    assert args.func(args) == 0
    assert "F_est median" in capsys.readouterr().out
    # unconverged chain: refused with one line, accepted with --force
    short = ["propagate", "--calibration-runs", str(path), "--A", "0.5", "--draws", "100",
             "--steps", "30", "--walkers", "18"]
    args = _parser().parse_args(short)
    with pytest.raises(ConvergenceError) as exc:
        args.func(args)
    assert "\n" not in str(exc.value)
    args = _parser().parse_args(short + ["--force", "--json"])
    assert args.func(args) == 0
    capsys.readouterr()
    # bad timestamp and too-short run
    bad = _runs_frame(3, seed=4)
    bad.loc[bad.index[3], "timestamp"] = "not a date"
    bad.to_csv(tmp_path / "bad.csv", index=False)
    args = _parser().parse_args(["propagate", "--calibration-runs", str(tmp_path / "bad.csv"),
                                 "--A", "0.5"])
    with pytest.raises(DpdfitError, match="timestamp"):
        args.func(args)
    _runs_frame(3, seed=4, bad_run=2).to_csv(tmp_path / "short.csv", index=False)
    args = _parser().parse_args(["propagate", "--calibration-runs",
                                 str(tmp_path / "short.csv"), "--A", "0.5"])
    with pytest.raises(DpdfitError, match="R003"):
        args.func(args)


def test_threshold_rows_match_scalar_first_crossing():
    from dpdfit.analyses.sweep import first_crossing_rows as _first_crossing_rows
    from dpdfit.analyses.sweep import first_crossing as _first_crossing
    rng = np.random.default_rng(3)
    x = np.sort(rng.uniform(0.01, 0.5, (50, 30)), axis=1)
    y = 1e-5 * (x / 0.01) ** rng.uniform(1.5, 3.5, (50, 1)) * rng.uniform(0.5, 2, (50, 30))
    for lev in (1e-2, 1e-3, 1e-4):
        rows = _first_crossing_rows(x, y, lev)
        for i in range(50):
            ref = _first_crossing(x[i], y[i], lev)
            assert (np.isnan(rows[i]) and ref is None) or rows[i] == pytest.approx(ref, rel=1e-12)


def test_threshold_distribution_brackets_the_point_estimate():
    """With a fresh table the draws' thresholds scatter around the sweep of the fit itself."""
    from dpdfit.simulation.aom_truth import BraggAOM, simulate_amplitude_run
    from dpdfit.analyses.propagation import threshold_distribution
    from dpdfit.fits.calibration import fit_amplitude
    from dpdfit.analyses.sweep import SweepConfig, run_sweep, thresholds
    from dpdfit.models.transfer import TransferFunction
    rng = np.random.default_rng(8)
    frames = []
    for k in range(3):
        d = simulate_amplitude_run(BraggAOM(A_corr=0.5655 + 0.005 * k), np.linspace(0, 1, 201), rng)
        d.insert(0, "run", f"R{k}")
        d.insert(1, "timestamp", pd.Timestamp("2026-01-01", tz="UTC") + pd.Timedelta(days=k))
        frames.append(d)
    df = pd.concat(frames, ignore_index=True)
    grid = np.linspace(0.05, 1.0, 40)
    dist = threshold_distribution(df, 0.0, draws=400, amplitudes=grid, seed=2)
    last = df[df.run == "R2"]
    fit = fit_amplitude(last.A, last.power, last.power_err)
    sw = run_sweep(TransferFunction(fit.powers, fit.coefficients),
                   SweepConfig(amplitudes=grid, am_only=True))
    point = thresholds(sw)["eta_th"]
    for flag in ("dpd", "no_dpd"):
        for lev in ("1e-2", "1e-3"):
            q = dist[flag][lev]
            assert q["q2.5"] <= point[flag][lev] <= q["q97.5"], (flag, lev, q, point[flag][lev])


def test_phase_perturbation_first_order_matches_exact_forward():
    """The draw-batched phase perturbation equals the exact forward model to first order."""
    import dataclasses
    from dpdfit.simulation.aom_truth import BraggAOM, simulate_amplitude_run, simulate_phase_run
    from dpdfit.fits.calibration import fit_amplitude, fit_phase
    from dpdfit.analyses.propagation import BatchedForwardModel as _Forward
    rng = np.random.default_rng(4)
    aom = BraggAOM()
    grid = np.linspace(0, 1, 201)
    d = simulate_amplitude_run(aom, grid, rng)
    fit = fit_amplitude(d.A, d.power, d.power_err)
    p = simulate_phase_run(aom, grid, rng)
    ph = fit_phase(p.A, p.phase_rad, p.phase_err)
    db = rng.multivariate_normal(np.zeros(5), np.asarray(ph.covariance))
    ph2 = dataclasses.replace(ph, coefficients=np.asarray(ph.coefficients) + db)
    a = np.asarray(fit.coefficients)[None, :]
    for dpd in (0, 1):
        approx = _Forward(fit, ph, 0.6).evaluate(a, dpd, db[None, :])
        exact = _Forward(fit, ph2, 0.6)
        # the LUT of ph2's forward model is the same (amplitude only); compare the field tones
        e = exact.evaluate(a, dpd)
        for k in ("F_est", "eta_bar"):
            assert approx[k] == pytest.approx(e[k], rel=1e-6, abs=1e-7)
        assert approx["R10_dB"] == pytest.approx(e["R10_dB"], abs=0.02)
