"""The bundled campaign: regenerated bit for bit by the simulator; analysed by `analyze`."""

import json

import pytest

from dpdfit.simulation.campaign import campaign_hashes, simulate_campaign
from tests.helpers.same_campaign import assert_same_campaign
from tests.helpers.paths import ROOT

BUNDLED = ROOT / "datasets" / "synthetic_campaign"
SEED = 20260329


def quiet(label, total):
    from dpdfit.core.progress import progress_bar
    return progress_bar(total=total, desc=label, disable=True)


@pytest.mark.slow
def test_simulator_regenerates_bundled_campaign(tmp_path):
    """Bit for bit where it was made; elsewhere equal up to the floating-point noise of
    the processor's BLAS kernel (tests/helpers/same_campaign.py says how much)."""
    out = tmp_path / "regen"
    simulate_campaign(out, seed=SEED, progress=quiet)
    bundled = campaign_hashes(BUNDLED)
    bundled.pop("REALISM.md")             # written by scripts/make_campaign.py from the analysis
    assert_same_campaign(out, BUNDLED, campaign_hashes(out), bundled)


def test_bundled_campaign_size():
    total = sum(p.stat().st_size for p in BUNDLED.parent.rglob("*") if p.is_file())
    assert total <= 30 * 2 ** 20


@pytest.mark.slow
def test_analyze_bundled_campaign(bundled_analysis):
    s = bundled_analysis.analysis.summary
    assert {k: v["status"] for k, v in s["analyses"].items()} == {
        "calibration": "ok", "stability": "ok", "sweep": "ok", "spectra": "ok", "traces": "ok",
        "gates": "ok", "propagation": "ok", "budget": "ok", "diagnosis": "ok"}
    assert s["diagnosis"]["verdict"] == "none"
    cal = s["calibration"]
    assert cal["n_amplitude_runs"] == 34 and cal["n_phase_runs"] == 6
    assert abs(cal["A_corr_runs_mean"] - 0.5655) < 3 * cal["A_corr_runs_std"] / 34 ** 0.5 + 0.002
    gain = s["spectra"]["R10_gain_dB_below_A_corr"]
    assert gain["mean"] > 2.0
    summary = json.loads((bundled_analysis.results / "summary.json").read_text())
    assert summary["realism"]
