"""What further recordings changed (``dpdfit diagnose --compare``): an earlier diagnosis's
alternatives settled or still open, the separation achieved between its proposal's
binding pair against the one predicted, another proposal, the evidence before and after.

The fast tests use synthetic diagnosis dicts and a minimal Diagnosis; the command line
is run with the diagnosis replaced by a stand-in.  One slow test takes a real ambiguous
harness campaign through the loop: diagnose, record the proposal, diagnose again with
``--compare``.
"""

from __future__ import annotations

import json
from types import SimpleNamespace

import pytest

import dpdfit.analyses.diagnosis.diagnose as diagnose_module
from dpdfit.analyses.diagnosis.comparison.compare import Comparison, compare_diagnoses
from dpdfit.analyses.diagnosis.decisions.alternatives import Alternative
from dpdfit.analyses.diagnosis.proposal.next_measurement import NextMeasurement
from dpdfit.analyses.diagnosis.comparison.previous import (read_diagnosis, refit_request,
                                                           unknown_in_binding)
from dpdfit.analyses.diagnosis.comparison.refits import (binding_chi2, binding_refits,
                                                         refitted_chi2)
from dpdfit.analyses.diagnosis.result import Diagnosis
from dpdfit.errors import InputError
from tests.helpers.cli_refusal import assert_refused
from tests.helpers.cli_run import run
from tests.helpers.diagnosis_dicts import (PROPOSAL, RIVAL, TRUTH, after as _after,
                                           alternative as _alt, before as _before,
                                           diagnosis as _diag, ranked as _rank,
                                           refit_entries as _refits)


def test_alternatives_are_settled_one_way_or_the_other_or_stay_open():
    c = compare_diagnoses(_before(), _after())
    status = {a["label"]: a["status"] for a in c.alternatives_before}
    assert status == {"detector_nonlinearity": "rejected",
                      "stale_calibration + dephasing": "named",
                      "spam_offset": "open"}
    assert [a["label"] for a in c.settled] == ["detector_nonlinearity",
                                               "stale_calibration + dephasing"]
    assert [a["label"] for a in c.still_open] == ["spam_offset"]
    # the open one's evidence now, against the named set
    assert c.still_open[0]["delta_bic_tempered_after"] == 6.0
    assert [a["label"] for a in c.new_alternatives] == [
        "stale_calibration + dephasing + motional_heating"]
    assert c.changed and c.named_after == ["stale_calibration", "dephasing"]
    assert c.previous_named_status == "named"         # named still, with an addition
    assert "verdict: stale_calibration -> stale_calibration   (named: stale_calibration -> " \
           "stale_calibration + dephasing)" in c.report()
    d = c.to_dict()
    assert d["settled"] == [{"hypothesis": "detector_nonlinearity", "how": "rejected"},
                            {"hypothesis": "stale_calibration + dephasing", "how": "named"}]
    assert d["still_open"] == ["spam_offset"]


def test_a_verdict_turned_to_an_alternative_is_said_so():
    before = _diag("spam_offset", ["spam_offset"],
                   [_alt("dephasing", ["dephasing"], "spam_offset")])
    after = _diag("dephasing", ["dephasing"], [_alt("spam_offset", ["spam_offset"],
                                                    "dephasing")])
    c = compare_diagnoses(before, after)
    assert c.alternatives_before[0]["status"] == "named"
    assert c.previous_named_status == "open" and not c.new_alternatives
    text = c.report()
    assert "verdict: spam_offset -> dephasing" in text
    assert "dephasing (now named)" in text
    assert "the previous verdict (spam_offset) is now an alternative" in text


def test_separation_achieved_against_predicted_from_the_refitted_pair():
    """|(240 - 200) - (110 - 100)| = 30 against 27 predicted; the refits are matched to
    the pair by their effects and forms, not by their order."""
    c = compare_diagnoses(_before(), _after())
    s = c.separation
    assert s["achieved"] == pytest.approx(30.0) and s["predicted"] == 27.0
    assert s["ratio"] == pytest.approx(30.0 / 27.0) and s["reason"] is None
    assert s["chi2_before"] == {"truth": 100.0, "rival": 110.0}
    assert s["chi2_after"] == {"truth": 200.0, "rival": 240.0}
    assert (s["predicted_if_truth"], s["predicted_if_rival"]) == (27.0, 45.0)
    assert (s["truth"], s["rival"], s["what"]) == ("stale_calibration",
                                                   "detector_nonlinearity", "spectra")
    assert (s["toward"], s["toward_label"], s["predicted_toward"]) == (
        "truth", "stale_calibration", 27.0)
    assert ("achieved 30 toward stale_calibration against 27 predicted were it true "
            "(ratio 1.11)") in c.report()


def test_a_recording_that_moved_toward_the_rival_is_measured_against_the_rivals_prediction():
    """The gap (rival - truth) went from 10 to -20: 30 toward the rival, against the 45
    predicted were the rival true (not the truth's 27: 1.11 would be about neither)."""
    c = compare_diagnoses(_before(), _after(refits=_refits(200.0, 180.0)))
    s = c.separation
    assert s["achieved"] == pytest.approx(30.0)
    assert (s["toward"], s["toward_label"], s["predicted_toward"]) == (
        "rival", "detector_nonlinearity", 45.0)
    assert s["ratio"] == pytest.approx(30.0 / 45.0) and s["reason"] is None
    assert ("achieved 30 toward detector_nonlinearity against 45 predicted were it true "
            "(ratio 0.67)") in c.report()
    # the rival's own figure missing: no ratio, and the line says why
    before = _before()
    before["next_measurement"]["binding"]["rival"]["expected_delta_bic"] = None
    c = compare_diagnoses(before, _after(refits=_refits(200.0, 180.0)))
    assert c.separation["ratio"] is None and c.separation["toward"] == "rival"
    assert "moved toward detector_nonlinearity, for which the previous proposal predicted " \
           "no separation" in c.report()
    # no movement at all: no direction, no ratio
    c = compare_diagnoses(_before(), _after(refits=_refits(200.0, 210.0)))
    assert c.separation["achieved"] == 0.0 and c.separation["toward"] is None
    assert c.separation["ratio"] is None and "did not move the pair apart" in c.report()


def test_the_separation_names_the_recording_it_was_predicted_for():
    """A lab may take another recording than the proposed one: the line says which one
    the prediction holds for (validation p04 was given 92 scans at A = 0.8 where the
    proposal was 220 at A = 0.4, and its ratio of 45 was about neither)."""
    before = _before()
    before["next_measurement"]["settings"] = {"A": 0.4, "dpd": 1, "shots": 612,
                                              "scans": 220}
    before["next_measurement"]["what"] = "populations"
    c = compare_diagnoses(before, _after())
    assert c.separation["settings"] == before["next_measurement"]["settings"]
    line = next(x for x in c.report().splitlines() if "separation of" in x)
    assert line.endswith("predicted were it true (ratio 1.11) for a population scan at A = 0.4 with "
                         "DPD, 220 scans (612 shots)"), line


def test_the_refit_helpers_shared_with_the_closed_loop():
    assert binding_refits(PROPOSAL) == [{"effects": ["stale_calibration"], "forms": ["aom"]},
                                        {"effects": ["detector_nonlinearity"],
                                         "forms": ["linear"]}]
    assert binding_chi2(PROPOSAL) == {"truth": 100.0, "rival": 110.0}
    assert refitted_chi2(PROPOSAL, _refits(1.0, 2.0)) == {"truth": 1.0, "rival": 2.0}
    assert refitted_chi2(PROPOSAL, _refits(1.0, 2.0)[:1]) is None     # one side missing
    for bad in (None, {}, {"what": "spectra"}, "text", {"binding": "x"},
                {"binding": {"truth": TRUTH}}):
        assert binding_refits(bad) is None and binding_chi2(bad) is None
    assert refit_request(_before()) == binding_refits(PROPOSAL)
    odd = {**PROPOSAL, "binding": {"truth": {**TRUTH, "effects": ["lab_specific"]},
                                   "rival": {**RIVAL, "forms": ["cubic"]}}}
    assert unknown_in_binding(odd) == ["lab_specific", "detector_nonlinearity[cubic]"]
    assert refit_request({**_before(), "next_measurement": odd}) is None


@pytest.mark.parametrize("prev_nxt, after_refits, needle", [
    (None, [], "the previous diagnosis proposed no recording"),
    ({"what": None, "reason": "no calibration runs to extend"}, [],
     "proposed no recording: no calibration runs to extend"),
    ({k: v for k, v in PROPOSAL.items() if k != "binding"}, [],
     "names no binding pair"),
    ({**PROPOSAL, "binding": {"truth": {"effects": ["a"], "forms": ["b"]},
                              "rival": {"effects": ["c"], "forms": ["d"]}}}, [],
     "does not carry its binding pair's chi2"),
    (PROPOSAL, [], "did not refit the previous proposal's binding pair"),
    ({**PROPOSAL, "expected_delta_bic": None}, None, "predicted no separation"),
])
def test_missing_pieces_are_said_not_guessed(prev_nxt, after_refits, needle):
    before = {**_before(), "next_measurement": prev_nxt}
    c = compare_diagnoses(before, _after(refits=after_refits))
    assert needle in c.separation["reason"]
    assert c.separation["ratio"] is None
    assert needle in c.report()
    json.dumps(c.to_dict())                    # nothing that JSON cannot hold


def test_a_previous_diagnosis_without_alternatives_or_proposal():
    before = _diag("spam_offset", ["spam_offset"], ranking=[_rank("spam_offset", -50.0)])
    before.pop("alternatives")
    before.pop("next_measurement")
    c = compare_diagnoses(before, _diag("spam_offset", ["spam_offset"]))
    assert c.alternatives_before == [] and not c.changed
    text = c.report()
    assert "verdict: spam_offset (unchanged)" in text
    assert "the previous diagnosis had no alternatives: none to settle" in text
    assert ("no separation to compare: the previous diagnosis had no alternatives and "
            "proposed no recording") in text
    assert "no further recording proposed (no alternatives" in text


@pytest.mark.parametrize("nxt, words", [
    (None, "no further recording proposed"),
    ({"what": None, "reason": "the menu's simulation failed"},
     "no further recording proposed (the menu's simulation failed)"),
    ({"what": "time_scan", "expected_delta_bic": 12.0, "decisive": False,
      "reason": "no recording of the menu separates them"},
     "another recording proposed: time scan, expected delta BIC 12, not decisive"),
    ({"what": "parity", "expected_delta_bic": 31.0, "decisive": True},
     "another recording proposed: parity, expected delta BIC 31"),
])
def test_whether_another_recording_is_proposed(nxt, words):
    c = compare_diagnoses(_before(), _after(nxt=nxt))
    assert c.next_measurement["proposed"] is bool(nxt and nxt.get("what"))
    assert words in c.report()


def test_evidence_of_each_effect_before_and_after():
    """Tempered delta BIC where the ranking has it, raw otherwise; the gap to the best;
    the role in each diagnosis; None where a diagnosis did not rank the effect."""
    c = compare_diagnoses(_before(), _after())
    rows = {r["effect"]: r for r in c.evidence}
    assert list(rows)[:2] == ["stale_calibration", "spam_offset"]        # later ranking
    st, dn = rows["stale_calibration"], rows["detector_nonlinearity"]
    assert (st["gap_before"], st["gap_after"]) == (0.0, 0.0)
    assert (dn["gap_before"], dn["gap_after"]) == (3.0, 60.0)
    assert (dn["role_before"], dn["role_after"]) == ("alternative", None)
    assert rows["dephasing"]["evidence_before"] == -20.0                 # raw: no tempered
    assert rows["dephasing"]["role_after"] == "named"
    assert rows["motional_heating"]["gap_before"] is None
    assert set(c.to_frame().columns) >= {"effect", "gap_before", "gap_after"}


def test_evidence_is_the_family_tempered_delta_bic_where_the_ranking_has_it():
    """Each effect's own tempering differs, so the ranking orders by its family's tempered
    evidence: that one is compared where given."""
    ranking = [{**_rank("a", -100.0, -40.0), "family_delta_bic_tempered": -95.0},
               {**_rank("b", -90.0, -85.0), "family_delta_bic_tempered": -88.0}]
    d = _diag("a", ["a"], ranking=ranking)
    rows = {r["effect"]: r for r in compare_diagnoses(d, d).evidence}
    assert (rows["a"]["gap_before"], rows["b"]["gap_before"]) == (0.0, 7.0)


def _minimal_diagnosis(**extra) -> Diagnosis:
    a = _after(**extra)
    return Diagnosis(campaign=a["campaign"], mismatches=[], ranking=a["ranking"],
                     verdict=a["verdict"], redchi_before={}, redchi_after={},
                     baseline=SimpleNamespace(chi2=1000.0, dof=900, nuisances={}),
                     chosen=None, baseline_p_value=1e-6, seconds=0.0,
                     effects=a["effects"],
                     alternatives=tuple(Alternative.from_dict(x) for x in a["alternatives"]),
                     proposal=(None if a["next_measurement"] is None
                               else NextMeasurement.from_dict(a["next_measurement"])),
                     refits=a["refits"])


def test_a_diagnosis_object_or_a_file_stand_for_its_dict(tmp_path):
    prev = tmp_path / "before.json"
    prev.write_text(json.dumps(_before()))
    from_dicts = compare_diagnoses(_before(), _after())
    for p in (prev, str(prev), _before()):
        c = compare_diagnoses(p, _minimal_diagnosis())
        assert isinstance(c, Comparison) and c.to_dict() == from_dicts.to_dict()
    assert "verdict after" in c._repr_html_() and "Comparison(" in repr(c)


@pytest.mark.parametrize("text, needle", [
    ("verdict: spam_offset\n", "not JSON"),
    ("[1, 2]", "not a dpdfit diagnosis (a JSON list"),
    ('{"verdict": "none"}', "no 'campaign', 'effects', 'ranking'"),
    ('{"campaign": "c", "verdict": 3, "effects": [], "ranking": []}', "'verdict' must be text"),
])
def test_a_previous_file_that_is_not_a_diagnosis_is_refused(tmp_path, text, needle):
    p = tmp_path / "previous.json"
    p.write_text(text)
    with pytest.raises(InputError) as err:
        read_diagnosis(p)
    msg = str(err.value)
    assert needle in msg and str(p) in msg and "\n" not in msg
    with pytest.raises(InputError):
        compare_diagnoses(p, _after())
    with pytest.raises(InputError, match="not found"):
        read_diagnosis(tmp_path / "absent.json")


CAMP = "datasets/synthetic_campaign"


@pytest.fixture
def stand_in(monkeypatch):
    """The CLI's diagnosis replaced by a minimal one; the refit it was asked for kept."""
    seen = []

    def fake(folder, pairs, progress, refit=None):
        seen.append(refit)
        return _minimal_diagnosis()
    # the command imports diagnose() when it runs: replaced in its module
    monkeypatch.setattr(diagnose_module, "diagnose", fake)
    return seen


@pytest.mark.parametrize("text, needle", [("{not json", "not JSON"),
                                          ('{"rows": []}', "not a dpdfit diagnosis")])
def test_cli_refuses_a_bad_previous_before_diagnosing(tmp_path, capsys, stand_in, text,
                                                      needle):
    prev = tmp_path / "previous.json"
    prev.write_text(text)
    out = tmp_path / "out"
    out.mkdir()
    plots = out / "plots"
    assert_refused(capsys, ["diagnose", CAMP, "--compare", prev, "--json", "--plot", plots],
                   [needle, str(prev)], inputs=[prev], no_partial_output_in=out)
    assert stand_in == [] and not plots.exists()                 # failed before any fit


def test_cli_compare_adds_the_comparison_key_report_and_figure(tmp_path, capsys, stand_in):
    prev = tmp_path / "previous.json"
    prev.write_text(json.dumps(_before()))
    code, out, err = run(["diagnose", CAMP, "--compare", prev, "--json"], capsys)
    assert code == 0, err
    d = json.loads(out)
    plain = _minimal_diagnosis().to_dict()
    assert set(d) == set(plain) | {"comparison"}                 # one key more, none renamed
    assert d["verdict"] == plain["verdict"]
    assert stand_in == [binding_refits(PROPOSAL)]                # the pair was refitted
    cmp = d["comparison"]
    assert cmp["separation"]["achieved"] == pytest.approx(30.0)
    assert cmp["still_open"] == ["spam_offset"] and cmp["verdict_before"] == "stale_calibration"
    code, out, err = run(["diagnose", CAMP, "--compare", prev, "--plot", tmp_path / "fig"],
                         capsys)
    assert code == 0, err
    assert "What the recording changed (previous diagnosis of before):" in out
    assert "  verdict: stale_calibration" in out
    assert (tmp_path / "fig" / "diagnosis_comparison.png").read_bytes()[:4] == b"\x89PNG"


def test_cli_without_compare_is_unchanged(capsys, stand_in):
    code, out, _ = run(["diagnose", CAMP, "--json"], capsys)
    assert code == 0 and "comparison" not in json.loads(out) and stand_in == [None]


def test_comparison_figure_draws_paired_bars():
    matplotlib = pytest.importorskip("matplotlib")
    from matplotlib.figure import Figure

    from dpdfit.report import comparison_figure
    assert matplotlib
    fig = comparison_figure(compare_diagnoses(_before(), _after()))
    assert isinstance(fig, Figure)
    pair, ax = fig.axes                                 # (a) the pair, (b) the effects
    assert len(ax.patches) == 9                         # 4 effects before, 5 after
    labels = [t.get_text() for t in ax.get_yticklabels()]
    assert "detector_nonlinearity (alt. -> -)" in labels
    assert "stale_calibration (named)" in labels
    empty = compare_diagnoses(_diag("none", []), _diag("none", []))
    assert comparison_figure(empty).axes[1].texts
    assert "no pair to compare" in comparison_figure(empty).axes[0].texts[0].get_text()


def test_pair_panel_draws_the_gap_before_and_after_and_what_was_expected():
    import dataclasses
    pytest.importorskip("matplotlib")
    from dpdfit.report import comparison_figure
    c = compare_diagnoses(_before(), _after())
    sep = {"what": "time_scan", "truth": "a + b", "rival": "a + c",
           "chi2_before": {"truth": 100.0, "rival": 95.0},
           "chi2_after": {"truth": 180.0, "rival": 110.0},
           "predicted_if_truth": 40.0, "predicted_if_rival": 60.0, "reason": None}
    pair = comparison_figure(dataclasses.replace(c, separation=sep)).axes[0]
    assert [round(p.get_width(), 9) for p in pair.patches] == [-5.0, -70.0]
    marks = sorted(float(line.get_xdata()[0]) for line in pair.lines
                   if line.get_marker() in ("v", "^"))
    assert marks == [-65.0, 35.0]          # -5 - 60 were c true, -5 + 40 were b true


#: a harness job whose diagnosis is ambiguous (stale_calibration, or
#: detector_nonlinearity) and proposes spectra (benchmarks/harness_runs_loop_2816.jsonl)
AMBIGUOUS_JOB = (2007339889, {"dephasing": {"f_cm": 0.9170468291872721,
                                            "rate": 143.70014407386918},
                              "stale_calibration": {"drift": 0.02014870469894613}})


@pytest.mark.slow
def test_cli_compare_on_a_real_ambiguous_campaign_against_itself(tmp_path, capsys):
    """No recording added: the refitted pair is where it was (separation achieved 0),
    the verdict unchanged and every alternative still open."""
    from dpdfit.simulation.campaign import simulate_campaign
    from dpdfit.simulation.harness import harness_config
    seed, effects = AMBIGUOUS_JOB
    camp = tmp_path / "campaign"
    simulate_campaign(camp, seed=seed, config=harness_config(seed).inject(effects),
                      progress=False)
    code, out, err = run(["diagnose", camp, "--json", "--no-progress"], capsys)
    assert code == 0, err
    prev = json.loads(out)
    assert prev["alternatives"] and binding_chi2(prev["next_measurement"]) is not None
    (tmp_path / "before.json").write_text(out)
    code, out, err = run(["diagnose", camp, "--compare", tmp_path / "before.json", "--json",
                          "--no-progress", "--plot", tmp_path / "fig"], capsys)
    assert code == 0, err
    d = json.loads(out)
    assert {k: d[k] for k in ("verdict", "alternatives", "ranking")} == {
        k: prev[k] for k in ("verdict", "alternatives", "ranking")}
    c = d["comparison"]
    assert c["verdict_before"] == c["verdict_after"] == prev["verdict"] and not c["changed"]
    assert c["settled"] == [] and len(c["still_open"]) == len(prev["alternatives"])
    s = c["separation"]
    assert s["chi2_before"] == pytest.approx(s["chi2_after"], rel=1e-9)
    assert s["achieved"] == pytest.approx(0.0, abs=1e-6 * s["chi2_before"]["truth"])
    assert s["predicted"] == prev["next_measurement"]["expected_delta_bic"]
    assert (tmp_path / "fig" / "diagnosis_comparison.png").exists()


def test_a_pair_the_new_campaign_cannot_fit_is_reported_not_raised(monkeypatch):
    """A form of the earlier pair that the new recordings no longer support: its refit
    gives no chi2 and a reason, the other side is still refitted."""
    from dpdfit.analyses.diagnosis.comparison import refits

    def refit_label(prob, base, label):
        if label["forms"] == ["aom_all"]:
            raise KeyError("aom_all")
        return 12.5

    monkeypatch.setattr(refits, "refit_label", refit_label)
    out = refits.refit_labels(None, None, [
        {"effects": ["stale_calibration"], "forms": ["aom_all"]},
        {"effects": ["dephasing"], "forms": ["coherence"]}])
    assert out[0]["chi2"] is None and "aom_all" in out[0]["reason"]
    assert out[1] == {"effects": ["dephasing"], "forms": ["coherence"], "chi2": 12.5}
    assert refits.refitted_chi2(
        {"binding": {"truth": out[0], "rival": out[1]}}, out) is None
