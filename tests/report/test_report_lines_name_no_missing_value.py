"""What the reports print: no ``nan`` where nothing was named, every symbol present, and
the one-line error of an alignment without gate-rate errors names ``gate_rates.csv``."""

import json
import shutil
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from dpdfit.analyses.budget import error_budget
from dpdfit.analyses.diagnosis.result import Diagnosis
from dpdfit.errors import InputError
from dpdfit.fits.alignment import align
from dpdfit.report.summary import summary_markdown
from tests.helpers.paths import ROOT

CAMPAIGN = ROOT / "datasets" / "synthetic_campaign"

REDCHI = {"tones:R10": 1.004, "gates:F_pop": 0.913}
#: a ranking entry as a null campaign's diagnosis has it: the form's fixed parameters
#: (here f_cm, beta) carry no error
RANKING = [{"effect": "dephasing", "variant": "during", "delta_bic": 5.2, "p_value": 0.4,
            "params": {"rate": 5.13, "f_cm": 0.0, "beta": 1.0},
            "params_err": {"rate": 2.55, "f_cm": float("nan"), "beta": float("nan")}}]


def _heating_entry(upper_limit: bool) -> str:
    cfg = {"heating": {"rate_per_ms": 0.02, "rate_err_per_ms": 0.005,
                       "upper_limit": upper_limit},
           "monte_carlo": {"samples": 2000}}
    line = next(x for x in error_budget(cfg).report().splitlines()
                if x.startswith("Motional heating"))
    return line.split()[-2]


def test_budget_heating_entry_prints_its_relation_to_the_heating_bound():
    assert _heating_entry(upper_limit=True) == "(dn<0.0062)"
    # a measured heating rate (not an upper limit) is equal, not missing its symbol
    assert _heating_entry(upper_limit=False) == "(dn=0.0062)"


def _null_diagnosis() -> Diagnosis:
    return Diagnosis(campaign="null", mismatches=[], ranking=RANKING, verdict="none",
                     redchi_before=dict(REDCHI), redchi_after=dict(REDCHI),
                     baseline=SimpleNamespace(chi2=694.0, dof=849), chosen=None,
                     baseline_p_value=0.99, seconds=1.0)


def test_diagnose_report_with_verdict_none_prints_no_first_effect_column():
    text = _null_diagnosis().report()
    assert "nan" not in text
    assert "first effect" not in text
    assert "reduced chi2 per observable (baseline; no effect named):" in text
    row = next(x for x in text.splitlines() if "tones:R10" in x)
    assert row.split() == ["tones:R10", "1.00"]


def test_diagnose_report_with_an_effect_keeps_baseline_first_effect_final():
    d = _null_diagnosis()
    named = Diagnosis(**{**d.__dict__, "verdict": "dephasing",
                         "redchi_one": {"tones:R10": 0.9, "gates:F_pop": 0.8},
                         "redchi_after": {"tones:R10": 0.8, "gates:F_pop": 0.7}})
    text = named.report()
    assert "(baseline -> first effect -> final):" in text
    row = next(x for x in text.splitlines() if "tones:R10" in x)
    assert row.split() == ["tones:R10", "1.00", "->", "0.90", "->", "0.80"]


def test_summary_md_prints_no_error_of_a_fixed_parameter():
    dg = {"verdict": "none", "baseline_p_value": 0.99, "mismatches": [],
          "ranking": RANKING, "redchi_before": REDCHI, "redchi_after": REDCHI}
    md = summary_markdown({"analyses": {}, "diagnosis": dg}, "null", "exact")
    assert "nan" not in md
    assert "| dephasing | 5.2 | 0.4 | rate = 5.13 +/- 2.5 |" in md


def _sweep() -> pd.DataFrame:
    """A sweep table's curves over the gate amplitudes (their values do not matter here)."""
    A = np.linspace(0.3, 0.9, 7)
    return pd.DataFrame([{"A": a, "dpd": d, "sideband": "mean", "r_rel": a, "F_est": 0.99,
                          "eta_bar": a} for d in (0, 1) for a in A])


def _gate_table() -> pd.DataFrame:
    return pd.DataFrame({"A": [0.4, 0.5, 0.4, 0.5], "dpd": [0, 0, 1, 1],
                         "xi0_khz": [3.3, 4.1, 3.6, 4.4], "F": [0.99] * 4,
                         "F_err": [0.002] * 4})


def test_alignment_without_rate_errors_or_power_band_names_file_and_column():
    gate = _gate_table()
    gate.attrs["rates_source"] = "lab/gate_rates.csv"
    with pytest.raises(InputError) as err:
        align(gate, _sweep(), sigma_db=0.0)
    assert str(err.value).startswith("lab/gate_rates.csv, column 'xi0_err_khz': no such column")
    # with the band, the same table aligns (the column is optional)
    assert align(gate, _sweep(), sigma_db=0.2).left_out


def test_analyze_gates_step_names_the_campaigns_gate_rates_csv(tmp_path):
    from dpdfit.pipeline.context import Context, Results
    from dpdfit.pipeline.steps.gates import gates_step
    from dpdfit.recordings.campaign_folder import CampaignFolder
    for name in ("populations.csv", "parity.csv"):
        shutil.copy(CAMPAIGN / name, tmp_path / name)
    meta = json.loads((CAMPAIGN / "campaign.json").read_text())
    meta["error_model"]["power_jitter_db"] = 0.0
    (tmp_path / "campaign.json").write_text(json.dumps(meta))
    rates = pd.read_csv(CAMPAIGN / "gate_rates.csv", comment="#")
    rates.drop(columns=["xi0_err_khz"]).to_csv(tmp_path / "gate_rates.csv", index=False)
    ctx = Context(campaign=CampaignFolder(tmp_path), results=Results(), formula="exact",
                  figures=None)
    with pytest.raises(InputError) as err:
        gates_step(ctx, SimpleNamespace(table=_sweep()))
    assert str(err.value).startswith(
        f"{tmp_path / 'gate_rates.csv'}, column 'xi0_err_khz': no such column")
    assert "campaign.json error_model.power_jitter_db" in str(err.value)
