"""gate_rates.csv has one reader with one set of rules: the campaign folder, `budget
--gate-rates` and `fidelity --gate-rates` read it alike, and the import mapping's
columns are the readers' own."""

import pandas as pd
import pytest

import dpdfit.analyses.budget as budget
from dpdfit.cli.main import main
from dpdfit.recordings.columns import CAMPAIGN_TABLES
from dpdfit.recordings.mapping import TABLE_COLUMNS
from tests.helpers.cli_refusal import assert_refused
from tests.helpers.paths import ROOT

CAMP = ROOT / "datasets" / "synthetic_campaign"


def _fidelity(rates, *extra):
    return ["fidelity", "--populations", CAMP / "populations.csv", "--parity",
            CAMP / "parity.csv", "--gate-rates", rates, *extra]


def _rates(tmp_path, edit):
    df = edit(pd.read_csv(CAMP / "gate_rates.csv", comment="#"))
    p = tmp_path / "rates.csv"
    df.to_csv(p, index=False)
    return p


def test_fidelity_takes_gate_rates_without_xi0_err_khz(tmp_path, capsys):
    rates = _rates(tmp_path, lambda df: df.drop(columns="xi0_err_khz"))
    out = tmp_path / "gate.csv"
    assert main([str(a) for a in _fidelity(rates, "-o", out)]) == 0, capsys.readouterr().err
    gate = pd.read_csv(out)
    assert gate["xi0_khz"].notna().all() and "xi0_err_khz" not in gate.columns


def test_fidelity_refuses_a_dpd_that_is_not_an_integer(tmp_path, capsys):
    def edit(df):
        df["dpd"] = df["dpd"].astype(float)
        df.loc[1, "dpd"] = 0.5
        return df
    rates = _rates(tmp_path, edit)
    assert_refused(capsys, _fidelity(rates), [str(rates), "column 'dpd'", "row 2",
                                              "must be 0 or 1"], [rates])


def test_fidelity_refuses_a_rate_below_the_minimum(tmp_path, capsys):
    def edit(df):
        df.loc[0, "xi0_khz"] = 1e-9
        return df
    rates = _rates(tmp_path, edit)
    assert_refused(capsys, _fidelity(rates), [str(rates), "column 'xi0_khz'", "row 1",
                                              "not a gate rate"], [rates])


@pytest.mark.parametrize("table", sorted(CAMPAIGN_TABLES))
def test_mapping_columns_are_the_readers(table):
    required, optional = CAMPAIGN_TABLES[table]
    m_required, m_optional = TABLE_COLUMNS[table]
    assert set(m_required) | set(m_optional) == set(required) | set(optional)
    # only the scan, which the import numbers, is optional in a mapping alone
    assert set(required) - set(m_required) <= {"scan"}
    assert set(m_required) <= set(required)


def test_budget_reader_says_what_it_returns():
    assert not hasattr(budget, "read_gate_rates")
    assert budget.gate_rates_khz(CAMP / "gate_rates.csv") == pytest.approx(
        pd.read_csv(CAMP / "gate_rates.csv", comment="#")["xi0_khz"].tolist())


def test_the_import_guide_lists_the_mapping_columns():
    import re
    guide = (ROOT / "docs" / "guide" / "import.md").read_text()
    for table, (required, optional) in TABLE_COLUMNS.items():
        row = next(line for line in guide.splitlines() if line.startswith(f"| `{table}` |"))
        names = set(re.findall(r"`(\w+)`", row)) - {table}
        assert names == set(required) | set(optional), (table, names)
