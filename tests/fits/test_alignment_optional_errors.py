"""The alignment runs without the gate rates' stated errors, and ``analyze`` uses the
campaign's laser-power fluctuation.

``xi0_err_khz`` is optional in ``gate_rates.csv``; the alignment fit (and so the
``gates`` step of ``analyze``) must run without it and say what it went without.
``analyze``'s alignment takes ``error_model.power_jitter_db`` from ``campaign.json``
(the lab's ``ERROR_MODEL`` value when the campaign states none).
"""

import json
import shutil

import numpy as np
import pandas as pd
import pytest

from dpdfit.analyses.sweep import SweepConfig, run_sweep
from dpdfit.core.defaults import ERROR_MODEL
from dpdfit.errors import InputError
from dpdfit.fits.alignment import K_DB, align, curves
from dpdfit.models.transfer import TransferFunction
from dpdfit.pipeline.analyze import analyze
from dpdfit.pipeline.steps.gates import power_jitter_db
from tests.helpers.paths import ROOT

CAMPAIGN = ROOT / "datasets" / "synthetic_campaign"


@pytest.fixture(scope="module")
def sweep():
    """A sweep of a smooth compressive transfer function (y = A - 0.3 A^3)."""
    tf = TransferFunction((1, 3), (1.0, -0.3))
    return run_sweep(tf, SweepConfig(amplitudes=np.linspace(0.3, 0.9, 25)))


def simulated_gate(sweep, rng, alpha=3.42, delta=-0.018, sdb=0.2):
    """Gate points on the sweep's curves with power jitter, rate and fidelity noise."""
    cv = curves(sweep)
    rows = []
    for d in (0, 1):
        for A in (0.4, 0.5, 0.6, 0.7, 0.8):
            r = float(cv[d]["r_rel"](A))
            s = 0.01 * alpha * r
            xi = alpha * r * (1 + K_DB * sdb * rng.standard_normal()) + s * rng.standard_normal()
            F = float(cv[d]["F_est"](A)) + delta + 0.004 * rng.standard_normal()
            rows.append({"A": A, "dpd": d, "xi0_khz": xi, "xi0_err_khz": s, "F": F,
                         "F_err": 0.004})
    return pd.DataFrame(rows)


def test_alignment_without_stated_rate_errors_is_the_fit_with_zero_errors(sweep):
    g = simulated_gate(sweep, np.random.default_rng(3))
    without = align(g.drop(columns="xi0_err_khz"), sweep, 0.2)
    zero = align(g.assign(xi0_err_khz=0.0), sweep, 0.2)
    for k in ("alpha_khz", "alpha_khz_err", "delta", "delta_err", "chi2"):
        assert getattr(without, k) == getattr(zero, k)
    assert without.left_out and "xi0_err_khz" in without.left_out[0]
    assert without.to_dict()["left_out"] == list(without.left_out)
    assert "left out" in without.report() and "xi0_err_khz" in without.report()
    assert "xi0_err_khz" not in without.points.columns
    # with the stated errors nothing is left out, and to_dict has no such key
    full = align(g, sweep, 0.2)
    assert full.left_out == () and "left_out" not in full.to_dict()


def test_power_jitter_is_the_campaigns_else_the_labs():
    assert power_jitter_db({}) == ERROR_MODEL.power_jitter_db
    assert power_jitter_db({"error_model": {"nbar": 0.1}}) == ERROR_MODEL.power_jitter_db
    assert power_jitter_db({"error_model": {"power_jitter_db": 0.35}}) == 0.35
    with pytest.raises(InputError, match="power_jitter_db"):
        power_jitter_db({"error_model": {"power_jitter_db": -1}})


def test_analyze_aligns_without_xi0_err_and_with_the_campaigns_jitter(tmp_path):
    camp = tmp_path / "campaign"
    shutil.copytree(CAMPAIGN, camp)
    rates = pd.read_csv(camp / "gate_rates.csv")
    rates.drop(columns="xi0_err_khz").to_csv(camp / "gate_rates.csv", index=False)
    meta = json.loads((camp / "campaign.json").read_text())
    meta["error_model"]["power_jitter_db"] = 0.35
    (camp / "campaign.json").write_text(json.dumps(meta))
    res = analyze(camp, plots=True, diagnosis=False, progress=False)
    assert res.summary["analyses"]["gates"]["status"] == "ok", res.summary["analyses"]["gates"]
    assert "xi0_err_khz" in res.summary["analyses"]["gates"]["detail"]
    fit = res.alignment
    assert fit is not None and fit.sigma_db == 0.35 and fit.left_out
    assert res.summary["gates"]["alignment"]["left_out"] == list(fit.left_out)
    assert res.outputs["budget"]       # the budget got the fitted delta
    figures = res.draw_figures()       # the gate figures draw without the error column
    assert any(stem.startswith("fig3") for stem in figures)
