"""External injection recovery: ``dpdfit harness --campaigns DIR --truth FILE``."""

import json
import shutil

import pytest

from dpdfit.cli.main import main
from dpdfit.simulation.harness_external import summarise_external
from tests.helpers.paths import TEST_DATA

DATA = TEST_DATA / "validation"


def _run(campaign, truth, verdict, seconds=1.0):
    return {"campaign": campaign, "truth": truth, "verdict": verdict, "seconds": seconds}


def test_summary_counts_and_rates():
    runs = [_run("a", "none", "none"), _run("b", "none", "dephasing"),
            _run("c", "dephasing", "dephasing"), _run("d", "aom_memory", "unexplained"),
            _run("e", "spam_offset", "refused"), _run("f", "unknown", "none", 5.0)]
    s = summarise_external(runs)
    assert s["n_campaigns"] == 6 and s["n_nulls"] == 2 and s["n_concealed"] == 3
    assert s["false_alarm_rate"] == 0.5
    assert s["named_correctly"] == pytest.approx(1 / 3)
    assert s["confusion"] == {"none": {"none": 1, "dephasing": 1},
                              "dephasing": {"dephasing": 1},
                              "aom_memory": {"unexplained": 1},
                              "spam_offset": {"refused": 1}, "unknown": {"none": 1}}
    assert s["n_refused"] == 1 and s["max_seconds"] == 5.0 and s["median_seconds"] == 1.0


@pytest.mark.parametrize("case, needle", [
    ("no_truth", "--campaigns DIR and --truth FILE go together"),
    ("missing_dir", "campaigns folder does not exist"),
    ("bad_json", "not valid JSON"),
    ("no_effect", "campaign 'v01': needs an object with a string 'effect'"),
    ("empty_dir", "no campaign folders"),
])
def test_bad_arguments_are_one_line_and_exit_2(tmp_path, capsys, case, needle):
    truth = tmp_path / "truth.json"
    truth.write_text(json.dumps({"v01": {"effect": "none"}}))
    camps = DATA
    args = ["harness", "--campaigns", str(camps), "--truth", str(truth)]
    if case == "no_truth":
        args = ["harness", "--campaigns", str(camps)]
    elif case == "missing_dir":
        args[2] = str(tmp_path / "nowhere")
    elif case == "bad_json":
        truth.write_text("{not json")
    elif case == "no_effect":
        truth.write_text(json.dumps({"v01": {"seed": 3}}))
    elif case == "empty_dir":
        (tmp_path / "empty").mkdir()
        args[2] = str(tmp_path / "empty")
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and needle in err[0], err


@pytest.mark.slow
def test_four_validation_campaigns_are_diagnosed_and_named(tmp_path, capsys):
    """Two nulls and two concealed effects of the independent simulator (copied from
    ../shared/validation_campaigns with their truth): none refused, every verdict right."""
    camps = tmp_path / "campaigns"
    shutil.copytree(DATA, camps, ignore=shutil.ignore_patterns("truth.json"))
    before = {p: p.read_bytes() for p in camps.rglob("*") if p.is_file()}
    out = tmp_path / "report.json"
    code = main(["harness", "--campaigns", str(camps), "--truth", str(DATA / "truth.json"),
                 "--workers", "2", "--json", "-o", str(out)])
    assert code == 0
    printed = json.loads(capsys.readouterr().out)
    rep = json.loads(out.read_text())
    assert printed["confusion"] == rep["confusion"]
    assert {"confusion", "false_alarm_rate", "named_correctly", "n_campaigns", "runs"} <= set(rep)
    assert rep["n_campaigns"] == 4 and len(rep["runs"]) == 4
    for r in rep["runs"]:
        assert {"campaign", "truth", "verdict", "seconds"} <= set(r)
        assert r["verdict"] == r["truth"], r
    assert rep["false_alarm_rate"] == 0 and rep["named_correctly"] == 1
    assert {p: p.read_bytes() for p in camps.rglob("*") if p.is_file()} == before
