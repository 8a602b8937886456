"""The harness's leave-one-form-out and triples modes: their plans, the run records' keys,
the figures per kind of run, resuming from the log, the command line, and (slow) one
left-out-form campaign end to end."""

import numpy as np
import pytest

import dpdfit.simulation.harness as H
from dpdfit.cli.main import main
from dpdfit.simulation.harness import concealed_effects, plan
from dpdfit.simulation.injections import get
from dpdfit.simulation.harness_kinds import by_kind, empty_families, forms_table, run_kind


def _forms(name):
    return [f.name for f in get(name).forms_for()]


def test_leave_one_form_out_plans_every_form_of_every_effect_with_that_form_left_out():
    jobs = plan(0, 0, seed=11, leave_one_form_out=True, per_form=2)
    want = [(e, f) for e in concealed_effects() for f in _forms(e)]
    got = [(j["concealed"], j["injected_form"][j["concealed"]]) for j in jobs]
    assert got == [x for x in want for _ in range(2)]
    for j in jobs:
        (e, v), = j["effects"].items()
        form = j["injected_form"][e]
        assert j["forms_left_out"] == {e: [form]}
        ranges = get(e).harness_table()[form]
        assert set(ranges) <= set(v)
        for p, x in get(e).form_values(form).items():
            assert v[p] == x                                  # injected in that form
    assert len({H._job_key(j) for j in jobs}) == len(jobs)


def test_leave_one_form_out_plan_is_deterministic_and_each_form_draws_on_its_own():
    a = plan(0, 0, seed=11, leave_one_form_out=True, per_form=1)
    assert a == plan(0, 0, seed=11, leave_one_form_out=True, per_form=1)
    assert a != plan(0, 0, seed=12, leave_one_form_out=True, per_form=1)
    # one family's jobs do not move with the others, nor with the catalog jobs before them
    only = plan(0, 0, seed=11, effects=("dephasing",), leave_one_form_out=True, per_form=1)
    assert only == [j for j in a if j["concealed"] == "dephasing"]
    mixed = plan(2, 1, seed=11, pairs=1, triples=1, leave_one_form_out=True, per_form=1)
    assert mixed[-len(a):] == a


def test_existing_plans_are_unchanged_by_the_new_modes():
    base = plan(2, 3, seed=5, pairs=4)
    assert plan(2, 3, seed=5, pairs=4, triples=2, leave_one_form_out=True)[:len(base)] == base
    assert all("forms_left_out" not in j for j in base)


def test_triples_conceal_three_distinct_effects_drawn_as_the_catalog_harness():
    jobs = plan(0, 0, seed=3, triples=5)
    assert jobs == plan(0, 0, seed=3, triples=5) and len(jobs) == 5
    order = list(concealed_effects())
    for j in jobs:
        names = j["concealed"].split("+")
        assert len(set(names)) == 3 and list(j["effects"]) == names
        assert names == sorted(names, key=order.index)
        for n, v in j["effects"].items():
            assert set(v) == set(get(n).harness)
        assert run_kind(j) == "triples"
    with pytest.raises(Exception, match="triples need at least three effects"):
        plan(0, 0, seed=3, triples=1, effects=("dephasing", "spam_offset"))


@pytest.mark.parametrize("kw, needle", [
    (dict(per_effect=0, nulls=0), "not all 0"),
    (dict(per_effect=0, nulls=0, leave_one_form_out=True, per_form=0), "--per-form >= 1"),
    (dict(per_effect=1, nulls=0, triples=-1), ">= 0"),
])
def test_bad_plans_are_refused_in_one_line(kw, needle):
    with pytest.raises(Exception) as exc:
        plan(seed=1, **kw)
    assert needle in str(exc.value) and "\n" not in str(exc.value)


@pytest.mark.parametrize("args", [["--per-effect", "0", "--nulls", "0", "--triples", "0"],
                                  ["--leave-one-form-out", "--per-form", "0"],
                                  ["--triples", "-1"]])
def test_harness_command_refuses_bad_modes(capsys, args):
    assert main(["harness", *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("dpdfit: error:")


def _record(job, named, alternatives=(), verdict=None, forms=None, sizes=None, empty=False):
    """A run record as run_one writes it, for a given outcome."""
    named = list(named)
    out = {**job, "named": named, "alternatives": [{"named": list(a)} for a in alternatives],
           "verdict": verdict or (named[0] if named else "none"),
           "named_correctly": sorted(named) == sorted(job["effects"]) if job["effects"]
           else (verdict or "none") == "none",
           "named_forms": forms or {}, "family_left_empty": empty,
           "injected_form": job.get("injected_form") or {
               e: get(e).forms_for()[0].name for e in job["effects"]},
           "redchi_before": 2.0, "redchi_after": 1.0, "seconds_simulation": 1.0,
           "seconds_diagnosis": 1.0}
    if sizes:
        out["truth_sizes"], out["fit_sizes"] = sizes
    return out


def test_figures_per_kind_of_run():
    cat = plan(2, 1, seed=5, effects=("spam_offset", "higher_order_im"))
    lofo = plan(0, 0, seed=5, effects=("dephasing", "higher_order_im"),
                leave_one_form_out=True, per_form=1)
    pair = plan(0, 0, seed=5, pairs=1, effects=("spam_offset", "dephasing"))[0]
    triple = plan(0, 0, seed=5, triples=1)[0]
    spam = {"spam_offset": {"extra_preparation": 0.01}}
    runs = [
        # catalog: right (with a size 0.5 sigma off), spurious extra, wrong out of reach,
        # right, and the null's false alarm
        _record(cat[0], ["spam_offset"], sizes=(spam, {"spam_offset": {"extra_preparation": {
            "value": 0.011, "error": 0.002}}})),
        _record(cat[1], ["spam_offset", "dephasing"]),
        _record(cat[2], ["dephasing"]),
        _record(cat[3], ["higher_order_im"]),
        _record(cat[4], ["dephasing"]),
        # left-out forms: dephasing named in another form, then wrong but in reach
        _record(lofo[0], ["dephasing"], forms={"dephasing": "mixed"}),
        _record(lofo[1], ["spam_offset"], alternatives=[["dephasing"]]),
        _record(pair, ["spam_offset"]),
        _record(triple, list(triple["effects"])),
    ]
    hoim = next(j for j in lofo if j["concealed"] == "higher_order_im")
    runs += [_record(hoim, [], verdict="unexplained", empty=True),
             _record(hoim, ["am_pm_omitted"], empty=True)]
    k = by_kind(runs)
    c = k["catalog"]
    assert (c["n_concealed"], c["exact_set"], c["spurious_extra"]) == (4, 0.5, 0.25)
    assert c["confidently_wrong"] == pytest.approx(0.5)    # the extra is wrong too
    assert c["n_nulls"] == 0 and k["nulls"]["false_alarm"] == 1.0
    assert k["overall"]["n_nulls"] == 1 and k["overall"]["false_alarm"] == 1.0
    cov = c["coverage"]["spam_offset"]
    assert cov["n"] == 1 and cov["coverage_1sigma"] == 1.0 and cov["pulls"] == [pytest.approx(0.5)]
    lo = k["leave_one_form_out"]
    assert lo["n_concealed"] == 2 and lo["exact_set"] == 0.5 and lo["confidently_wrong"] == 0
    assert k["pairs"]["exact_set"] == 0 and k["triples"]["exact_set"] == 1
    assert k["overall"]["n_concealed"] == 8                 # the empty family kept apart
    assert empty_families(runs) == {"higher_order_im": {
        "n": 2, "unexplained": 1, "none": 0, "named_other": 1,
        "named_other_effects": {"am_pm_omitted": 1}}}
    table = forms_table(runs)["dephasing"]
    first = lofo[0]["injected_form"]["dephasing"]
    assert table[first]["named_forms"] == {"mixed": 1}
    s = H.summarise(runs)
    text = H.report({**s, "seconds": 1.0})
    for needle in ("leave_one_form_out", "triples", "higher_order_im: n=2, unexplained 1",
                   f"dephasing without {first}"):
        assert needle in text, needle
    # the keys of earlier harnesses describe the catalog-form singles and the pairs
    assert s["named_correctly_overall"] == 0.5 and s["pairs_both_named"] == 0


def test_the_log_keeps_runs_of_one_seed_with_different_forms_left_out(tmp_path, monkeypatch):
    calls = []

    def fake_run_one(job, workdir=None):
        calls.append(H._job_key(job))
        return _record(job, list(job["effects"]))

    monkeypatch.setattr(H, "run_one", fake_run_one)
    kw = dict(per_effect=0, nulls=0, workers=1, seed=5, effects=("spam_offset",),
              leave_one_form_out=True, per_form=1)
    jobs = plan(0, 0, seed=5, effects=("spam_offset",), leave_one_form_out=True, per_form=1)
    # the same campaign seed with two different forms left out: two runs
    jobs[1]["seed"] = jobs[0]["seed"]
    monkeypatch.setattr(H, "plan", lambda *a, **k: [dict(j) for j in jobs])
    log = tmp_path / "runs.jsonl"
    s1 = H.run_harness(log=log, **kw)
    assert len(calls) == 2 and s1["n_runs"] == 2
    calls.clear()
    s2 = H.run_harness(log=log, **kw)
    assert calls == [] and s2["n_runs"] == 2
    assert {tuple(r["forms_left_out"]["spam_offset"]) for r in s2["runs"]} == {
        ("total",), ("split",)}


@pytest.mark.slow
def test_one_left_out_form_campaign_end_to_end(tmp_path):
    """One campaign: AM-to-PM in the modulator (form ``aom``), diagnosed without that
    form; the record says what was injected, what was left out and what was named."""
    job = next(j for j in plan(0, 0, seed=11, effects=("am_pm_omitted",),
                               leave_one_form_out=True, per_form=1)
               if j["injected_form"]["am_pm_omitted"] == "aom")
    r = H.run_one(job, workdir=str(tmp_path), closed_loop=False)
    assert r["forms_left_out"] == {"am_pm_omitted": ["aom"]}
    assert r["injected_form"] == {"am_pm_omitted": "aom"}
    assert "aom" not in r["forms_fitted"]["am_pm_omitted"] and not r["family_left_empty"]
    assert r["named_forms"].get("am_pm_omitted") in (None, "post")
    assert r["exact_set"] == r["named_correctly"]
    assert {"confidently_wrong", "spurious_extra", "unexplained"} <= set(r)
    assert np.isfinite(r["truth_sizes"]["am_pm_omitted"]["am_pm_rad"])
    s = H.summarise([r])
    assert s["by_kind"]["leave_one_form_out"]["n_concealed"] == 1
    assert list(s["forms_left_out"]["am_pm_omitted"]) == ["aom"]


def test_pairs_and_triples_with_left_out_forms_are_drawn_apart_and_reproducibly():
    """Two or three effects at once, each in a form of its own left out of the catalog:
    families of one form never (left out, they could not be named), the other jobs of
    the plan unchanged, the same jobs for the same seed."""
    base = plan(per_effect=1, nulls=1, seed=21, pairs=2)
    mixed = plan(per_effect=1, nulls=1, seed=21, pairs=2, pairs_left_out=4,
                 triples_left_out=3)
    assert mixed[:len(base)] == base
    extra = mixed[len(base):]
    assert [len(j["effects"]) for j in extra] == [2] * 4 + [3] * 3
    for j in extra:
        assert set(j["forms_left_out"]) == set(j["effects"]) == set(j["injected_form"])
        for e, forms in j["forms_left_out"].items():
            assert forms == [j["injected_form"][e]]
            assert len(get(e).forms_for()) > 1
    assert extra == plan(per_effect=1, nulls=1, seed=21, pairs=2, pairs_left_out=4,
                         triples_left_out=3)[len(base):]
