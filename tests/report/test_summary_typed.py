"""``summary.json``'s realism table and sections are made from the steps' typed results.

The realism table takes the Bell fidelities and the alignment from the gates step's
:class:`GateResults` (no key of the form ``"A=0.5,dpd=1"`` is parsed back), the
budget's terms are listed once (the budget step), and the propagation step hands
down one typed entry per table age.
"""

from types import SimpleNamespace

import pandas as pd

from dpdfit.analyses.budget import error_budget
from dpdfit.pipeline.steps.budget import budget_summary
from dpdfit.pipeline.steps.gates import GateResults, gates_summary
from dpdfit.pipeline.steps.propagation import (AgedPropagation, PropagationResults,
                                               propagation_summary)
from dpdfit.report.summary import realism_table, summary_markdown


def _gate_table() -> pd.DataFrame:
    return pd.DataFrame({"A": [0.3, 0.5, 0.5], "dpd": [1, 0, 1], "F": [0.99, 0.95, 0.97],
                         "F_err": [0.01, 0.004, 0.003], "F_pop": [0.99, 0.96, 0.98],
                         "F_par": [0.99, 0.94, 0.96]})


def _realism(rows, start) -> dict:
    return {r["quantity"]: r["dpdfit"] for r in rows if r["quantity"].startswith(start)}


def test_realism_gate_rows_come_from_the_typed_gate_results():
    g = GateResults(table=_gate_table())
    assert g.fidelity(0.5, 1) == {"F": 0.97, "F_err": 0.003, "F_pop": 0.98, "F_par": 0.96}
    assert g.fidelity(0.7, 1) is None
    rows = _realism(realism_table({}, g), "Bell")
    assert rows == {"Bell fidelity at A=0.5, dpd": "0.9700 +/- 0.0030",
                    "Bell fidelity at A=0.5, no_dpd": "0.9500 +/- 0.0040"}
    fit = SimpleNamespace(alpha_khz=3.4, alpha_khz_err=0.05, delta=-0.02, delta_err=0.004)
    rows = realism_table({}, GateResults(table=_gate_table(), alignment=fit))
    assert _realism(rows, "alpha") == {"alpha (kHz)": "3.400 +/- 0.050"}
    assert _realism(rows, "delta") == {"delta": "-0.0200 +/- 0.0040"}
    # the gates section's string keys are for readers only: nothing parses them back
    summary = {"gates": gates_summary(g)}
    assert "A=0.5,dpd=1" in summary["gates"]["fidelities"]
    assert set(_realism(realism_table(summary), "Bell").values()) == {None}


def test_budget_terms_are_listed_once_and_rendered_in_their_order():
    section = budget_summary(error_budget(None))
    md = summary_markdown({"analyses": {}, "budget": section}, "campaign", "exact")
    rendered = [line.split("|")[1].strip() for line in md.splitlines()
                if line.startswith("| ") and line.count("|") == 4
                and line.split("|")[1].strip() in section]
    assert rendered == [k for k, v in section.items() if isinstance(v, dict)]


def _aged(days: float, median: float) -> AgedPropagation:
    flags = {f: {"F_est_median": median, "F_est_q2.5": median - 1e-3,
                 "F_est_q97.5": median + 1e-3} for f in ("dpd", "no_dpd")}
    result = SimpleNamespace(to_dict=lambda: {**flags, "tau": 30.0 + days,
                                              "n_independent": 100.0})
    thresholds = {f: {lev: {"median": 0.5} for lev in ("1e-2", "1e-3", "1e-4")}
                  for f in ("dpd", "no_dpd")}
    return AgedPropagation(days, result, thresholds)


def test_propagation_results_are_typed_per_table_age():
    p = PropagationResults(by_age=(_aged(0.0, 0.99), _aged(30.0, 0.98)), A=0.5, draws=10)
    assert p.stale_days == (0.0, 30.0)
    assert list(p.to_dict()) == ["stale_days=0", "stale_days=30"]
    assert p.to_dict()["stale_days=30"]["thresholds"] == p.by_age[1].thresholds
    s = propagation_summary(p)
    assert s["results"]["stale_days=30"]["dpd"]["F_est_median"] == 0.98
    assert s["tau"] == 60.0 and s["A"] == 0.5 and s["draws"] == 10
    assert s["thresholds"]["stale_days=0"]["no_dpd"]["1e-3"] == 0.5
