"""`dpdfit fidelity`, `dpdfit align` and the gate analysis of `analyze` on the bundled campaign."""

import json

import numpy as np
import pandas as pd
import pytest

from tests.helpers.cli_refusal import assert_refused
from tests.helpers.cli_run import run
from tests.helpers.paths import ROOT

CAMP = ROOT / "datasets" / "synthetic_campaign"
KEYS = ["A", "dpd", "F_pop", "F_pop_err", "F_par", "F_par_err", "F", "F_err", "contrast",
        "phi0", "n_scans", "shots", "interval_method"]


def test_fidelity_cli_json_and_csv(tmp_path, capsys):
    code, out, err = run(["fidelity", "--populations", CAMP / "populations.csv", "--parity",
                          CAMP / "parity.csv", "--json", "--gate-rates", CAMP / "gate_rates.csv",
                          "-o", tmp_path / "gate.csv", "--plot", tmp_path / "figs"], capsys)
    assert code == 0, err
    recs = json.loads(out)
    assert len(recs) == 10
    for r in recs:
        for k in KEYS:
            assert k in r
        assert r["n_scans"] == 4
        assert r["F"] == pytest.approx((r["F_pop"] + r["F_par"]) / 2)
        assert r["F_err"] == pytest.approx(0.5 * np.hypot(r["F_pop_err"], r["F_par_err"]))
    pop = pd.read_csv(CAMP / "populations.csv")
    tot = pop.groupby(["A", "dpd"])["shots"].sum()
    assert {(r["A"], r["dpd"]): r["shots"] for r in recs} == tot.to_dict()
    gate = pd.read_csv(tmp_path / "gate.csv")
    assert list(gate.columns[:len(KEYS)]) == KEYS
    assert {"xi0_khz", "xi0_err_khz"} <= set(gate.columns)
    assert (tmp_path / "figs" / "figS7_parity_fringes.png").exists()
    # align on the same table
    sweep = tmp_path / "sweep.csv"
    assert run(["calibrate", "--amplitude", CAMP / "calibration_amplitude.csv", "--run", "R034",
                "--phase", CAMP / "calibration_phase.csv", "--phase-run", "P006",
                "-o", tmp_path / "cal.json", "--order-scan", "none"], capsys)[0] == 0
    assert run(["sweep", tmp_path / "cal.json", "--amplitudes", "0.3:0.9:40", "-o", sweep],
               capsys)[0] == 0
    code, out, err = run(["align", "--gate", tmp_path / "gate.csv", "--sweep", sweep, "--json",
                          "--plot", tmp_path / "figs"], capsys)
    assert code == 0, err
    d = json.loads(out)
    for k in ("alpha_khz", "alpha_khz_err", "delta", "delta_err", "correlation", "redchi"):
        assert isinstance(d[k], float)
    truth = json.loads((CAMP / "truth.json").read_text())
    assert abs(d["alpha_khz"] - truth["config"]["alpha_khz"]) < 3 * d["alpha_khz_err"]
    assert (tmp_path / "figs" / "fig3_fidelity_vs_rate.png").exists()


@pytest.mark.parametrize("text, needle", [
    ("A,dpd,scan,n_even,shots\n0.5,1,1,700,625\n", "exceeds shots"),
    ("A,dpd,scan,n_even,shots\n0.5,1,1,-3,625\n", "negative"),
    ("A,dpd,scan,n_even,shots\n0.5,1,1,3.5,625\n", "integer"),
    ("A,dpd,scan,n_even,shots\n0.5,1,1,0,0\n", "shots"),
])
def test_fidelity_bad_population_counts(tmp_path, capsys, text, needle):
    p = tmp_path / "pop.csv"
    p.write_text(text)
    line = assert_refused(capsys, ["fidelity", "--populations", p, "--parity", CAMP / "parity.csv"],
                          [needle], [p], no_partial_output_in=tmp_path)
    assert "pop.csv" in line and "row 1" in line


def test_fidelity_too_few_phases(tmp_path, capsys):
    p = tmp_path / "par.csv"
    p.write_text("A,dpd,scan,phase_rad,n_even,shots\n0.5,1,1,0.0,600,625\n0.5,1,1,1.0,300,625\n")
    pop = tmp_path / "pop.csv"
    pop.write_text("A,dpd,scan,n_even,shots\n0.5,1,1,600,625\n")
    assert_refused(capsys, ["fidelity", "--populations", pop, "--parity", p], ["3"], [p, pop],
                   no_partial_output_in=tmp_path)


@pytest.mark.slow
def test_analyze_gate_analysis(bundled_analysis):
    s, res = bundled_analysis
    assert s.summary["analyses"]["gates"]["status"] == "ok"
    al = s.summary["gates"]["alignment"]
    assert abs(al["alpha_khz"] - 3.42) < 3 * al["alpha_khz_err"]
    figs = {p.name for p in (res / "figures").iterdir()}
    assert {"fig3_fidelity_vs_rate.png", "fig4_fidelity_vs_eta.png", "figS6_time_scans.png",
            "figS7_parity_fringes.png"} <= figs
    assert (res / "gate.csv").exists()
