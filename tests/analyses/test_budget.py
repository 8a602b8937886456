"""Error budget (Supplement S10, Table S2): formulas vs the exact gate engine,
Monte-Carlo propagation, config validation, CLI JSON."""

import argparse
import json
import math

import numpy as np
import pytest

from dpdfit.analyses import budget as bd
from dpdfit.cli import budget as budget_cli
from dpdfit.models import gate_sim as gs
from dpdfit.errors import InputError

S = 1 / np.sqrt(1.5)
N_C = np.array([1, 2])
R_C = np.array([S, -S])
XI0 = 1 / 250e-6
T_G = 1 / XI0
EO = XI0 / gs.calibrate_xi0(R_C, R_C, N_C, 1.0)
NONE = dict(T2=np.inf, ndot=0.0, p_prep=0.0, p_det=0.0)


def _sim(**kw):
    p = dict(NONE)
    p.update(kw)
    return gs.simulate_setting(R_C, R_C, N_C, EO, XI0, nbar=0.1, **p)


@pytest.fixture(scope="module")
def ideal():
    return _sim()


@pytest.fixture(scope="module")
def default():
    return bd.error_budget(None)


# --------------------------------------------------------------------------- Table S2


def test_default_reproduces_table_s3(default):
    d = default.to_dict()
    pm = d["paper"]["method_values"]
    # the paper's own arithmetic on the default inputs gives its table
    assert pm["state_preparation"] == pytest.approx(0.006)
    assert pm["dephasing"][0] == pytest.approx(0.003, abs=2e-4)
    assert pm["dephasing"][1] == pytest.approx(0.006, abs=3e-4)
    assert pm["detection"] == pytest.approx(2e-4)
    assert pm["heating_delta_nbar"] == pytest.approx(0.0031)
    assert pm["total"][0] == pytest.approx(0.009, abs=3e-4)
    assert pm["total"][1] == pytest.approx(0.012, abs=5e-4)
    # ours: dephasing = 0.591 x contrast loss at the ends of the range
    s = default.sources
    for key, T in (("at_T_min", 150e-6), ("at_T_max", 310e-6)):
        contrast = 1 - math.exp(-T / 0.05)
        assert s["dephasing"][key] / contrast == pytest.approx(0.591, rel=0.02)
    assert 0.0017 < s["dephasing"]["at_T_min"] < s["dephasing"]["at_T_max"] < 0.0038
    # preparation: the loss of the measured fidelity is ~ p per ion, not 2 p
    assert s["state_preparation"]["median"] < 0.006
    assert 0.003 < s["state_preparation"]["estimate"] < 0.0045      # truncated at A <= 1
    assert s["heating"]["upper_95"] < 8e-4
    assert s["detection"]["upper_95"] < 3e-4
    assert d["total"]["estimate"] < pm["total"][0]
    assert d["delta"] == {"estimate": -0.018, "error": 0.003}
    u = d["unexplained"]
    assert u["estimate"] == pytest.approx(0.018 - d["total"]["estimate"], abs=2e-4)
    assert u["error"] == pytest.approx(math.hypot(0.003, d["total"]["error"]), rel=0.02)
    assert d["p_unexplained_positive"] > 0.99
    rep = default.report()
    for word in ("State preparation", "dephasing", "heating", "detection", "Total",
                 "Table S2", "Unexplained", "0.3-0.6%"):
        assert word in rep
    assert "Table S2" not in default.report(paper=False)


def test_deterministic_seed():
    a = bd.error_budget({"monte_carlo": {"samples": 5000}}).to_dict()
    b = bd.error_budget({"monte_carlo": {"samples": 5000}}).to_dict()
    assert a == b


# --------------------------------------------------------------------------- vs gate_sim


def test_ideal_engine(ideal):
    assert ideal.apparent_fidelity == pytest.approx(1.0, abs=1e-9)


def test_dephasing_formula_vs_gate_sim(ideal):
    for T2 in (50e-3, 10e-3):
        r = _sim(T2=T2)
        loss = ideal.apparent_fidelity - r.apparent_fidelity
        assert bd.dephasing_loss(T_G, T2) == pytest.approx(loss, rel=0.03)
        # the parity contrast loses T/T2: the measured fidelity 0.591 of that
        contrast_loss = 1 - r.parity_fit()[0]
        assert contrast_loss == pytest.approx(T_G / T2, rel=0.03)
        assert loss / contrast_loss == pytest.approx(0.591, rel=0.03)


def test_heating_formula_vs_gate_sim(ideal):
    assert bd.heating_coefficient() == pytest.approx(0.25, rel=1e-6)
    r = _sim(ndot=100.0)
    loss = ideal.apparent_fidelity - r.apparent_fidelity
    assert bd.heating_loss(100.0, T_G) == pytest.approx(loss, rel=0.03)


@pytest.mark.parametrize("p", [0.003, 0.02])
def test_preparation_formula_vs_gate_sim(ideal, p):
    r = _sim(p_prep=p)
    loss = ideal.apparent_fidelity - r.apparent_fidelity
    assert bd.preparation_loss(p) == pytest.approx(loss, rel=1e-6)
    # F_pop unchanged, parity contrast x (1-p)^2
    assert r.pop[0] + r.pop[2] == pytest.approx(1.0, abs=1e-9)
    assert r.parity_fit()[0] == pytest.approx((1 - p) ** 2, rel=1e-8)


@pytest.mark.parametrize("p", [1e-4, 5e-3])
def test_detection_formula_vs_gate_sim(ideal, p):
    r = _sim(p_det=p)
    loss = ideal.apparent_fidelity - r.apparent_fidelity
    assert bd.detection_loss(p) == pytest.approx(loss, rel=1e-6)
    assert r.parity_fit()[0] == pytest.approx((1 - 2 * p) ** 2, rel=1e-8)


def test_combined_sum_vs_gate_sim(ideal):
    T2, ndot, pp, pd = 50e-3, 10.0, 0.003, 1e-4
    r = _sim(T2=T2, ndot=ndot, p_prep=pp, p_det=pd)
    loss = ideal.apparent_fidelity - r.apparent_fidelity
    pred = (bd.dephasing_loss(T_G, T2) + bd.heating_loss(ndot, T_G) + bd.preparation_loss(pp)
            + bd.detection_loss(pd))
    assert pred == pytest.approx(loss, rel=0.02)


# --------------------------------------------------------------------------- Monte Carlo


def test_mc_matches_analytic_gaussian():
    A, sA, T2, sT2 = 0.98, 0.001, 50.0, 1.0
    cfg = {"state_preparation": {"rabi_amplitude": A, "rabi_amplitude_err": sA},
           "dephasing": {"T2_ms": T2, "T2_err_ms": sT2},
           "gate": {"time_min_us": 200.0, "time_max_us": 200.0},
           "heating": {"rate_per_ms": 0.0}, "detection": {"error_per_ion": 0.0}}
    r = bd.error_budget(cfg)
    p = 1 - A
    prep = r.sources["state_preparation"]
    assert prep["estimate"] == pytest.approx(p - p * p / 2, rel=2e-3)
    assert prep["error"] == pytest.approx((1 - p) * sA, rel=0.01)          # dF/dA = -(1-p)
    deph = r.sources["dephasing"]
    T = 200e-6
    assert deph["estimate"] == pytest.approx(0.591 * T / (T2 * 1e-3), rel=2e-3)
    assert deph["error"] == pytest.approx(0.591 * T / (T2 * 1e-3) * sT2 / T2, rel=0.02)
    assert r.total["error"] == pytest.approx(math.hypot(prep["error"], deph["error"]), rel=0.02)
    lo, hi = prep["interval_68"]
    assert (hi - lo) / 2 == pytest.approx(prep["error"], rel=0.02)


def test_upper_limits_are_uniform():
    r = bd.error_budget({"gate": {"time_min_us": 300.0, "time_max_us": 300.0}})
    h = r.sources["heating"]
    full = bd.heating_loss(10.0, 300e-6)                  # at the limit 0.01 quanta/ms
    assert h["estimate"] == pytest.approx(full / 2, rel=0.01)
    assert h["error"] == pytest.approx(full / math.sqrt(12), rel=0.01)
    assert h["upper_95"] == pytest.approx(0.95 * full, rel=0.01)
    r2 = bd.error_budget({"heating": {"upper_limit": False, "rate_per_ms": 0.005,
                                      "rate_err_per_ms": 0.0}})
    assert r2.sources["heating"]["error"] == pytest.approx(0.0, abs=1e-15)


def test_delta_disabled_and_gate_rates():
    r = bd.error_budget({"delta": {"enabled": False}, "gate": {"rates_khz": [4.0, 5.0]}})
    d = r.to_dict()
    assert d["delta"] is None and d["unexplained"] is None
    assert r.gate_times_us == pytest.approx((200.0, 225.0, 250.0))
    assert "Unexplained" not in r.report()


# --------------------------------------------------------------------------- config


@pytest.mark.parametrize("cfg, word", [
    ({"bogus": {}}, "'bogus'"),
    ({"dephasing": {"T2": 50}}, "'dephasing.T2'"),
    ({"dephasing": {"T2_ms": "50"}}, "'dephasing.T2_ms'"),
    ({"dephasing": {"T2_ms": 0}}, "'dephasing.T2_ms'"),
    ({"heating": {"rate_per_ms": -0.01}}, "'heating.rate_per_ms'"),
    ({"heating": {"upper_limit": 1}}, "'heating.upper_limit'"),
    ({"detection": {"error_per_ion": True}}, "'detection.error_per_ion'"),
    ({"state_preparation": {"rabi_amplitude": 1.2}}, "'state_preparation.rabi_amplitude'"),
    ({"gate": {"rates_khz": [3.4, -1]}}, "'gate.rates_khz'"),
    ({"gate": {"time_min_us": 400.0}}, "'gate.time_min_us'"),
    ({"monte_carlo": {"samples": 10}}, "'monte_carlo.samples'"),
    ({"delta": 0.1}, "'delta'"),
])
def test_config_validation(cfg, word):
    with pytest.raises(InputError, match=word.replace(".", r"\.")):
        bd.error_budget(cfg)


def test_load_budget_config(tmp_path):
    p = tmp_path / "budget.toml"
    p.write_text("[dephasing]\nT2_ms = 40\n\n[delta]\nvalue = -0.02\n")
    cfg = bd.load_budget_config(p)
    assert cfg["dephasing"]["T2_ms"] == 40.0 and cfg["delta"]["value"] == -0.02
    assert cfg["heating"]["rate_per_ms"] == 0.01                      # defaults filled in
    bad = tmp_path / "bad.toml"
    bad.write_text("[heating]\nrate = 0.01\n")
    with pytest.raises(InputError, match=r"bad\.toml.*'heating\.rate'"):
        bd.load_budget_config(bad)
    bad.write_text("[heating\n")
    with pytest.raises(InputError, match="invalid TOML"):
        bd.load_budget_config(bad)


# --------------------------------------------------------------------------- CLI


def _parser():
    p = argparse.ArgumentParser(prog="dpdfit")
    budget_cli.add_budget_command(p.add_subparsers(dest="command"))
    return p


def test_cli_json(tmp_path, capsys):
    cfg = tmp_path / "b.toml"
    cfg.write_text("[monte_carlo]\nsamples = 20000\n")
    rates = tmp_path / "rates.csv"
    rates.write_text("A,dpd,xi0_khz\n0.4,0,3.349\n0.8,1,6.495\n")
    args = _parser().parse_args(["budget", "--config", str(cfg), "--delta", "-0.02",
                                 "--delta-err", "0.004", "--gate-rates", str(rates), "--json"])
    assert args.func is budget_cli.cmd_budget
    assert args.func(args) == 0
    d = json.loads(capsys.readouterr().out)
    for k in ("state_preparation", "dephasing", "heating", "detection", "total", "unexplained"):
        assert set(d[k]) == {"estimate", "error"}
        assert all(isinstance(v, float) for v in d[k].values())
    assert d["delta"] == {"estimate": -0.02, "error": 0.004}
    assert d["details"]["gate_times_us"]["max"] == pytest.approx(1e3 / 3.349)
    args = _parser().parse_args(["budget"])
    assert args.func(args) == 0
    assert "Table S2" in capsys.readouterr().out


def test_cli_bad_rates(tmp_path):
    rates = tmp_path / "rates.csv"
    rates.write_text("A,dpd,xi0\n0.4,0,3.349\n")
    args = _parser().parse_args(["budget", "--gate-rates", str(rates)])
    with pytest.raises(InputError, match="xi0_khz"):
        args.func(args)
