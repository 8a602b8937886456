"""The closed loop: a further recording added to a harness campaign, the random choice from
the menu, the loop's record, and the harness summary's ambiguity keys.

The extensions are checked on a reduced harness campaign (seconds each): the campaign
with the further recording has exactly the added rows, and every file it already had
is unchanged up to them (the new rows come last; truth.json records the config).
"""

from __future__ import annotations

import dataclasses
from collections import Counter
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

import dpdfit.simulation.closed_loop as C
import dpdfit.simulation.harness as H
from dpdfit.errors import InputError
from dpdfit.simulation.campaign import simulate_campaign
import dpdfit.simulation.further_recordings as F
from dpdfit.simulation.closed_loop import close_loop
from dpdfit.simulation.injections import get
from dpdfit.simulation.further_recordings import (default_menu, extend_config,
                                                  random_menu_choice)

SEED = 4242


def small_config(effects=None):
    """The harness campaign, reduced: one gate amplitude, one scan, four spectra amplitudes."""
    cfg = dataclasses.replace(H.harness_config(SEED), gate_amplitudes=(0.4,), time_scan_A=0.4,
                              scan_shots=((300, 300),), time_scan_points=5,
                              trace_amplitudes=(0.2, 0.4, 0.6, 0.8), n_amp_runs=5,
                              runs_after_recordings=1, cal_points=41)
    return cfg.inject(effects or {})


def _simulate(folder, cfg, gates=True):
    simulate_campaign(folder, seed=SEED, config=cfg, progress=False, include_gates=gates)
    return folder


@pytest.fixture(scope="module")
def base_cal(tmp_path_factory):
    return _simulate(tmp_path_factory.mktemp("loop") / "base_cal", small_config(), gates=False)


@pytest.fixture(scope="module")
def base_gates(tmp_path_factory):
    return _simulate(tmp_path_factory.mktemp("loop") / "base_gates", small_config())


def _added(base, ext) -> dict:
    """Lines added to each file of ``base`` in ``ext``; every file must be unchanged up to
    them (truth.json aside: it records the config)."""
    added = {}
    for p in sorted(base.iterdir()):
        if not p.is_file() or p.name == "truth.json":
            continue
        old, new = p.read_text(), (ext / p.name).read_text()
        assert new.startswith(old), f"{p.name}: a recording of the campaign was re-drawn"
        if new != old:
            added[p.name] = new[len(old):].count("\n")
    return added


def _extended(base, tmp_path, measurement, gates=True):
    ext = _simulate(tmp_path / "ext", extend_config(small_config(), measurement), gates)
    return ext, _added(base, ext)


def test_amplitude_run_is_one_more_run_after_the_last(base_cal, tmp_path):
    ext, added = _extended(base_cal, tmp_path, {"what": "amplitude_run",
                                                "settings": {"runs": 1}}, gates=False)
    assert added == {"calibration_amplitude.csv": 41}
    amp = pd.read_csv(ext / "calibration_amplitude.csv")
    assert list(dict.fromkeys(amp.run))[-1] == "R006"
    starts = pd.to_datetime(amp.groupby("run", sort=False).timestamp.first())
    assert starts.iloc[-1] > starts.iloc[-2]


def test_phase_run_is_one_more_phase_run(base_cal, tmp_path):
    ext, added = _extended(base_cal, tmp_path, {"what": "phase_run", "settings": {"runs": 2}},
                           gates=False)
    assert added == {"calibration_phase.csv": 2 * 41}
    ph = pd.read_csv(ext / "calibration_phase.csv")
    assert list(dict.fromkeys(ph.run)) == ["P001", "P002", "P003", "P004"]


def test_spectra_are_added_at_their_amplitudes_a_recorded_one_recorded_again(base_cal,
                                                                              tmp_path):
    ext, added = _extended(base_cal, tmp_path, {"what": "spectra", "settings": {
        "amplitudes": [0.3, 0.6, 0.95, 0.2, 0.6], "dpd": [0, 1]}}, gates=False)
    sp = pd.read_csv(ext / "spectra.csv")
    per_amplitude = 2 * 2 * len(small_config().spectra_harmonics)     # flags x sidebands
    assert added == {"spectra.csv": 5 * per_amplitude}
    # 0.6 and 0.2 were recorded: they are recorded again at exactly those amplitudes, as
    # repeated rows of the same tones (0.6 twice more), never shifted beside them
    assert sorted(set(sp.A)) == [0.2, 0.3, 0.4, 0.6, 0.8, 0.95]
    per_tone = sp.groupby(["A", "dpd", "sideband", "n"]).size()
    assert per_tone.loc[0.6].eq(3).all() and per_tone.loc[0.2].eq(2).all()
    assert per_tone.loc[0.4].eq(1).all() and per_tone.loc[0.95].eq(1).all()
    assert set(sp[sp.A == 0.95].dpd) == {0, 1}
    assert not hasattr(C, "REPEAT_STEP")
    # the campaign folder reads the repeats and pools them: one row per tone
    from dpdfit.recordings.campaign_folder import CampaignFolder
    pooled = CampaignFolder(ext).pooled_spectra
    assert len(pooled) == len(per_tone)
    assert pooled.set_index(["A", "dpd", "sideband", "n"])["n_repeats"].sort_index().equals(
        per_tone.sort_index().rename("n_repeats"))


def test_populations_scan_at_a_gate_setting_adds_one_population_row(base_gates, tmp_path):
    ext, added = _extended(base_gates, tmp_path, {"what": "populations", "settings": {
        "A": 0.4, "dpd": 1, "shots": 500}})
    assert added == {"populations.csv": 1}
    new = pd.read_csv(ext / "populations.csv").iloc[-1]
    assert (new.A, new.dpd, new.scan, new.shots) == (0.4, 1, 2, 500)


def test_parity_scan_at_a_gate_setting_adds_one_parity_scan(base_gates, tmp_path):
    """Parity shots are the scan's total over its phases (as the proposal counts them)."""
    par0 = pd.read_csv(base_gates / "parity.csv")
    n_phases = int((par0.scan == 1).sum() / 2)
    ext, added = _extended(base_gates, tmp_path, {"what": "parity", "settings": {
        "A": 0.4, "dpd": 0, "shots": 25 * n_phases}})
    assert added == {"parity.csv": n_phases}
    new = pd.read_csv(ext / "parity.csv").iloc[-n_phases:]
    assert set(new.scan) == {2} and set(new.shots) == {25} and set(new.dpd) == {0}


def test_scan_at_a_new_amplitude_is_a_new_setting(base_gates, tmp_path):
    ext, added = _extended(base_gates, tmp_path, {"what": "populations", "settings": {
        "A": 0.7, "dpd": 1, "shots": 625}})
    assert added["gate_rates.csv"] == 1 and added["populations.csv"] == 1
    assert set(added) == {"gate_rates.csv", "populations.csv", "parity.csv"}
    par = pd.read_csv(ext / "parity.csv")
    assert set(par[par.A == 0.7].scan) == {1}


def test_time_scan_adds_its_points_on_the_campaign_grid(base_gates, tmp_path):
    """``points`` counts the points after the start (as the diagnosis does): with the
    campaign's number, the new scan repeats the recorded times."""
    points = small_config().time_scan_points - 1
    ext, added = _extended(base_gates, tmp_path, {"what": "time_scan", "settings": {
        "A": 0.4, "dpd": 1, "shots": 200, "points": points}})
    assert added == {"time_scans.csv": points + 1}
    ts = pd.read_csv(ext / "time_scans.csv")
    new, old = ts.iloc[-points - 1:], ts.iloc[:-points - 1]
    assert set(new.shots) == {200} and set(new.A) == {0.4} and new.t_us.iloc[0] == 0
    assert np.array_equal(new.t_us, old[(old.A == 0.4) & (old.dpd == 1)].t_us)


def test_hundreds_of_scans_of_a_setting_share_the_engine(base_gates, tmp_path):
    """A proposal that fills its lab time with scans (here 60 population scans and two
    time scans again) is recorded with the engine's work shared between the scans
    (:mod:`dpdfit.simulation.campaign.further_engine`); the rows are the recording's."""
    m = {"what": "populations", "settings": {"A": 0.4, "dpd": 1, "shots": 625, "scans": 60}}
    cfg = extend_config(extend_config(small_config(), m), {"what": "time_scan", "settings": {
        "A": 0.4, "dpd": 1, "shots": 625, "scans": 2}})
    ext = _simulate(tmp_path / "ext", cfg)
    added = _added(base_gates, ext)
    points = small_config().time_scan_points
    assert added == {"populations.csv": 60, "time_scans.csv": 2 * points}
    pop = pd.read_csv(ext / "populations.csv").iloc[-60:]
    assert pop.scan.tolist() == list(range(2, 62)) and set(pop.shots) == {625}
    # the scans scatter as binomial draws at a jittered power: the even fraction's spread
    # is close to binomial (the jitter adds little at these shots)
    f = (pop.n00 + pop.n11) / pop.shots
    binom = np.sqrt(f.mean() * (1 - f.mean()) / 625)
    assert 0.7 * binom < f.std() < 1.5 * binom


def test_further_amplitude_run_carries_the_injected_drift(tmp_path):
    """The further run is drifted by the injected effects like any run after the recordings
    (the same draws with and without the injection: only the effect differs)."""
    v = {"drift": 0.05, "kappa": 0.0, "tau_d": 5.0}
    m = {"what": "amplitude_run", "settings": {"runs": 1}}
    runs = []
    for i, effects in enumerate(({}, {"stale_calibration": v})):
        truth = simulate_campaign(tmp_path / str(i), seed=SEED, progress=False,
                                  config=extend_config(small_config(effects), m),
                                  include_gates=False)
        runs.append(truth["calibration"]["amplitude_runs"])
    cfg = small_config()
    day_k = runs[0][cfg.n_amp_runs - 1 - cfg.runs_after_recordings]["day"]
    d = runs[0][-1]["day"]
    assert runs[0][-1]["further"] and runs[1][-1]["day"] == d
    expected = 1 + get("stale_calibration").inject_aom(
        get("stale_calibration").injected(v), np.array([d - day_k]),
        np.array([d - day_k - cfg.recording_hours[0] / 24]))[0]
    assert runs[1][-1]["A_corr"] / runs[0][-1]["A_corr"] == pytest.approx(expected, rel=1e-12)
    assert expected > 1


@pytest.mark.parametrize("m", [
    {"what": None, "reason": "nothing separates"},
    {"what": "lunch"},
    {"what": "spectra", "settings": {"amplitudes": [], "dpd": [0, 1]}},
    {"what": "spectra", "settings": {"amplitudes": [0.5], "dpd": [1]}},
    {"what": "populations", "settings": {"A": 1.5, "dpd": 0, "shots": 10}},
    {"what": "parity", "settings": {"A": 0.4, "dpd": 2, "shots": 10}},
    {"what": "time_scan", "settings": {"A": 0.4, "dpd": 0, "shots": 10, "points": 0}},
    {"what": "amplitude_run", "settings": {"runs": 0}},
])
def test_measurements_that_cannot_be_added_are_refused(m):
    with pytest.raises(InputError):
        extend_config(small_config(), m)


def test_default_menu_is_valid_and_the_random_choice_is_uniform_over_kinds():
    cfg = H.harness_config(SEED)
    rng = np.random.default_rng(1)
    for m in default_menu(rng, cfg):
        assert extend_config(cfg, m) != cfg
    kinds = Counter(F.MEASUREMENTS[random_menu_choice(rng, {"what": "spectra"}, cfg)["what"]]
                    for _ in range(2000))
    assert set(kinds) == {"amplitude_run", "phase_run", "spectra", "scan", "time_scan"}
    assert all(abs(n / 2000 - 0.2) < 0.04 for n in kinds.values()), kinds


def test_random_choice_draws_from_the_menu_when_there_is_one():
    cfg = H.harness_config(SEED)
    menu = [{"what": "parity", "settings": {"A": 0.6, "dpd": 1, "shots": 100}},
            {"what": "populations", "settings": {"A": 0.8, "dpd": 0, "shots": 100}},
            {"what": "parity", "settings": {"A": 0.4, "dpd": 0, "shots": 100}},
            "phase_run"]
    rng = np.random.default_rng(2)
    picks = [random_menu_choice(rng, {"what": "parity", "menu": menu}, cfg)
             for _ in range(1000)]
    kinds = Counter(F.MEASUREMENTS[p["what"]] for p in picks)
    assert set(kinds) == {"scan", "phase_run"} and abs(kinds["scan"] / 1000 - 0.5) < 0.06
    assert all(p["settings"] == {"runs": 1} for p in picks if p["what"] == "phase_run")


def test_random_choice_keeps_the_menu_entrys_lab_time():
    # the random arm's time to resolution is summed from its steps' lab_seconds: an
    # entry drawn from a menu that states its lab time must carry it
    cfg = H.harness_config(SEED)
    menu = [{"what": "parity", "settings": {"A": 0.6, "dpd": 1, "shots": 100},
             "lab_seconds": 42.0},
            {"what": "phase_run", "settings": {"runs": 1}, "lab_seconds": 300.0}]
    rng = np.random.default_rng(3)
    picks = [random_menu_choice(rng, {"what": "parity", "menu": menu}, cfg)
             for _ in range(50)]
    assert {p["what"] for p in picks} == {"parity", "phase_run"}
    assert all(p["lab_seconds"] == {"parity": 42.0, "phase_run": 300.0}[p["what"]]
               for p in picks)
    bare = random_menu_choice(rng, {"what": "parity", "menu": ["phase_run"]}, cfg)
    assert "lab_seconds" not in bare


JOB = {"concealed": "dephasing", "seed": SEED, "effects": {"dephasing": {"rate": 50.0}}}
ALTS = [{"effect": "spam_offset", "delta_bic": 1.0, "delta_bic_tempered": 0.5,
         "named": ["spam_offset"]}]
PROPOSAL = {"what": "parity", "settings": {"A": 0.6, "dpd": 1, "shots": 625},
            "expected_delta_bic": 4.0, "separates": ["dephasing", "spam_offset"],
            "lab_seconds": 60.0, "per_hour": 4.0, "menu": [
                {"what": "parity", "settings": {"A": 0.6, "dpd": 1, "shots": 625}},
                {"what": "spectra", "settings": {"amplitudes": [0.2625], "dpd": [0, 1]}}]}


def _stub(named, alternatives=(), proposal=None, verdict=None):
    extra = {"alternatives": list(alternatives)}
    if proposal is not None:
        extra["next_measurement"] = proposal
    return SimpleNamespace(named=list(named), verdict=verdict or (named[0] if named else "none"),
                           extra=extra)


def test_close_loop_is_none_unless_ambiguous_or_wrong(monkeypatch):
    assert close_loop(JOB, _stub(["dephasing"])) is None
    assert close_loop(JOB, _stub(["dephasing"], proposal=PROPOSAL)) is None
    # the dict form (to_dict: extra at the top level) and a run record
    assert close_loop(JOB, {"verdict": "dephasing", "named": ["dephasing"],
                            "alternatives": []}) is None
    # ambiguous, or wrong, without a proposal: the proposal arm records none, the random
    # arm still takes its recordings
    monkeypatch.setattr(C, "simulate_campaign",
                        lambda folder, seed, config, progress: folder.mkdir()
                        or (folder / "truth.json").write_text("{}"))
    monkeypatch.setattr(C, "_diagnose", lambda folder, refit=None: _stub(["dephasing"]))
    for first in (_stub(["dephasing"], ALTS, {"what": None, "reason": "x"}),
                  _stub(["spam_offset"])):
        out = close_loop(JOB, first)
        assert out["recommended"]["n_steps"] == 0 and not out["recommended"]["resolved"]
        assert out["recommended"]["reason"] == "no measurement was proposed"
        assert out["random"]["n_steps"] == 1 and out["random"]["resolved"]


def test_close_loop_rediagnoses_with_the_proposal_and_a_random_choice(monkeypatch):
    seen = []

    def fake_simulate(folder, seed, config, progress):
        seen.append(config.further or config.trace_amplitudes[-1])
        folder.mkdir()
        (folder / "truth.json").write_text("{}")

    def fake_diagnose(folder, refit=None):   # the proposal resolves; else still ambiguous
        if seen[-1] == (("scan", 0.6, 1, 0, 625 // 16),):
            return _stub(["dephasing"])
        return _stub(["dephasing"], ALTS)

    monkeypatch.setattr(C, "simulate_campaign", fake_simulate)
    monkeypatch.setattr(C, "_diagnose", fake_diagnose)
    out = close_loop(JOB, {"verdict": "dephasing", "named": ["dephasing"],
                           "alternatives": ALTS, "next_measurement": PROPOSAL})
    rec, rnd = out["recommended"], out["random"]
    assert rec["what"] == "parity" and rec["resolved"] and not rec["ambiguous_after"]
    assert rec["named"] == ["dephasing"]
    assert rnd["what"] in ("parity", "spectra")
    assert rnd["resolved"] == (rnd["what"] == "parity")
    # the proposal resolves at once; a random arm that does not is tried again, up to
    # LOOP_STEPS recordings, and never turns the verdict wrong here
    assert rec["n_steps"] == 1 and rec["resolved_final"] and not rec["turned_wrong"]
    assert 1 <= rnd["n_steps"] <= C.LOOP_STEPS
    assert rnd["resolved_final"] == any(st["resolved"] for st in rnd["steps"])
    again = close_loop(JOB, _stub(["dephasing"], ALTS, PROPOSAL))
    assert again["random"]["what"] == rnd["what"]             # seeded by the job's seed


def test_close_loop_records_a_measurement_it_cannot_take(monkeypatch):
    monkeypatch.setattr(C, "_diagnose", lambda folder, refit=None: pytest.fail(
        "nothing to diagnose"))
    bad = {**PROPOSAL, "what": "lunch", "menu": [{"what": "lunch"}]}
    monkeypatch.setattr(C, "random_menu_choice", lambda rng, m, cfg: bad)
    out = close_loop(JOB, _stub(["dephasing"], ALTS, bad))
    assert out["recommended"]["error"].startswith("InputError")
    assert out["recommended"]["resolved"] is False


def _record(concealed, named, verdict=None, alternatives=None, loop=None, **kw):
    effects = {} if concealed == "none" else {e: {} for e in concealed.split("+")}
    verdict = verdict or (named[0] if named else "none")
    r = {"concealed": concealed, "seed": len(named) + 7, "effects": effects,
         "verdict": verdict, "named": named,
         "named_correctly": sorted(named) == sorted(effects) if effects else verdict == "none",
         "redchi_before": 2.0, "redchi_after": 1.0, "seconds_simulation": 1.0,
         "seconds_diagnosis": 1.0, **kw}
    if alternatives is not None:
        r.update(alternatives=alternatives, ambiguous=bool(alternatives),
                 next_measurement=PROPOSAL if loop else None, closed_loop=loop)
    return r


def test_summary_counts_ambiguity_confident_errors_and_the_closed_loop():
    alt = [{"effect": "spam_offset", "named": ["spam_offset"], "delta_bic": 1.0,
            "delta_bic_tempered": 1.0}]
    runs = [
        _record("dephasing", ["spam_offset"], alternatives=[]),          # confidently wrong
        _record("spam_offset", ["dephasing"], alternatives=alt,          # truth among alts
                loop={"recommended": {"resolved": True}, "random": {"resolved": False}}),
        _record("none", ["dephasing"], alternatives=[]),                 # null false alarm
        _record("none", [], alternatives=[]),
        _record("dephasing+spam_offset", ["dephasing", "spam_offset"],
                alternatives=[{"effect": "dephasing", "named": ["dephasing"]}],
                loop={"recommended": {"resolved": False, "error": "InputError: x"},
                      "random": {"resolved": True}}),
        _record("dephasing", ["dephasing"]),                             # an older record
        {"concealed": "none", "seed": 99, "effects": {}, "error": "RuntimeError: lost"},
    ]
    s = H.summarise(runs)
    assert s["n_runs"] == 6
    assert s["ambiguous_rate"] == pytest.approx(2 / 6)
    assert s["confidently_wrong_rate"] == pytest.approx(2 / 6)
    cl = s["closed_loop"]
    assert {k: cl[k] for k in ("n", "resolved_recommended", "resolved_random", "n_failed")
            } == {"n": 2, "resolved_recommended": 0.5, "resolved_random": 0.5, "n_failed": 1}
    # records of a one-step loop: the final state is the first step's
    assert cl["resolved_recommended_final"] == 0.5 and cl["turned_wrong_recommended"] == 0
    assert cl["separation_ratios"] == [] and cl["separation_ratio_median"] is None
    assert s["false_alarm_rate"] == 0.5 and "recovery" in s       # the older keys stay
    text = H.report({**s, "seconds": 1.0})
    assert "ambiguous: 0.333, confidently wrong: 0.333" in text
    assert "closed loop (2 ambiguous with a proposal)" in text


def test_separation_ratios_are_also_given_over_the_steps_whose_premise_held():
    steps = [{"separation_predicted": 20.0, "separation_achieved": 18.0, "premise_held": True,
              "separation_predicted_for_truth": 20.0},
             {"separation_predicted": 10.0, "separation_achieved": 0.0, "premise_held": False},
             {"separation_predicted": 10.0, "separation_achieved": 13.0, "premise_held": True,
              "separation_predicted_for_truth": 10.0}]
    loop = {"recommended": {"resolved": False, "steps": steps},
            "random": {"resolved": False}}
    alt = [{"effect": "spam_offset", "named": ["spam_offset"]}]
    cl = H.summarise([_record("dephasing", ["dephasing"], alternatives=alt,
                              loop=loop)])["closed_loop"]
    assert cl["separation_ratios"] == pytest.approx([0.9, 0.0, 1.3])
    assert cl["separation_ratio_median"] == pytest.approx(0.9)
    assert cl["separation_ratios_premise_held"] == pytest.approx([0.9, 1.3])
    assert cl["separation_ratio_median_premise_held"] == pytest.approx(1.1)
    text = "\n".join(C.loop_report_lines(cl | {"ambiguous_rate": 1.0, "closed_loop": cl}))
    assert "median 0.9 over 3 recordings (1.1 over the 2 whose premise held)" in text


def test_predictions_are_held_to_their_replicates_and_lab_time_to_resolution_is_summed():
    steps = [{"separation_predicted": 30.0, "separation_achieved": 12.0, "premise_held": True,
              "separation_predicted_for_truth": 30.0, "separation_p10_for_truth": 15.0,
              "lab_seconds": 600.0, "resolved": False},
             {"separation_predicted": 30.0, "separation_achieved": 40.0, "premise_held": True,
              "separation_predicted_for_truth": 30.0, "separation_p10_for_truth": 20.0,
              "lab_seconds": 1200.0, "resolved": True}]
    alt = [{"effect": "spam_offset", "named": ["spam_offset"]}]
    loops = [{"recommended": {"resolved": False, "steps": steps},
              "random": {"resolved": False, "steps": [{"lab_seconds": 60.0,
                                                       "resolved": False}]}},
             {"recommended": {"resolved": True, "steps": [{"lab_seconds": 7200.0,
                                                          "resolved": True}]},
              "random": {"resolved": True, "steps": [{"lab_seconds": 300.0,
                                                      "resolved": True}]}}]
    cl = H.summarise([_record("dephasing", ["dephasing"], alternatives=alt, loop=lp)
                      for lp in loops])["closed_loop"]
    # one of the two promised recordings reached its 10th percentile
    assert cl["n_p10"] == 2 and cl["p10_held"] == pytest.approx(0.5)
    # resolved after 600 + 1200 s, and after 7200 s: median 4500 s; random: 300 s
    assert cl["lab_seconds_to_resolution_recommended"] == pytest.approx(4500.0)
    assert cl["lab_seconds_to_resolution_random"] == pytest.approx(300.0)
    text = "\n".join(C.loop_report_lines(cl | {"ambiguous_rate": 1.0, "closed_loop": cl}))
    assert "10th percentile: 1 of 2 recordings" in text
    assert "lab time to resolution, median: proposal 1.25 h, random 0.0833 h" in text


def test_summary_of_runs_without_ambiguity():
    s = H.summarise([_record("dephasing", ["dephasing"])])
    assert s["ambiguous_rate"] == 0 and s["confidently_wrong_rate"] == 0
    assert s["closed_loop"]["n"] == 0 and s["closed_loop"]["resolved_recommended"] is None


def test_run_harness_threads_the_closed_loop_switch(monkeypatch):
    seen = []

    def fake_run_one(job, workdir=None, closed_loop=True):
        seen.append(closed_loop)
        return {**_record(job["concealed"], sorted(job["effects"]), alternatives=[]),
                "seed": job["seed"]}

    monkeypatch.setattr(H, "run_one", fake_run_one)
    kw = dict(per_effect=1, nulls=1, workers=1, seed=5, effects=("dephasing",), progress=False)
    H.run_harness(**kw)
    H.run_harness(closed_loop=False, **kw)
    assert seen == [True, True, False, False]


@pytest.mark.slow
def test_harness_campaign_keeps_its_recordings_under_every_extension(tmp_path):
    """The full harness campaign (with an injected effect): each kind adds only its rows."""
    cfg = H.harness_config(SEED).inject({"motional_heating": {"ndot": 0.1}})
    base = tmp_path / "base"
    simulate_campaign(base, seed=SEED, config=cfg, progress=False)
    menu = default_menu(np.random.default_rng(3), cfg)
    for i, m in enumerate(menu):
        ext = tmp_path / f"ext{i}"
        simulate_campaign(ext, seed=SEED, config=extend_config(cfg, m), progress=False)
        assert _added(base, ext), m


def test_loop_steps_record_the_separation_achieved_and_a_verdict_turned_wrong(monkeypatch):
    """A proposal's binding pair is refitted after its recording: the separation achieved
    is how far the recording moved the pair apart; a recording that turns a verdict with
    the truth among its alternatives into a confidently wrong one is counted."""
    binding = {"truth": {"effects": ["spam_offset"], "forms": ["total"], "chi2": 100.0,
                         "expected_delta_bic": 27.0},
               "rival": {"effects": ["dephasing"], "forms": ["independent"], "chi2": 110.0,
                         "expected_delta_bic": 45.0}}
    proposal = {**PROPOSAL, "expected_delta_bic": 27.0, "binding": binding}
    seen = []

    def fake_simulate(folder, seed, config, progress):
        folder.mkdir()
        (folder / "truth.json").write_text("{}")

    def fake_diagnose(folder, refit=None):
        seen.append(refit)
        d = _stub(["spam_offset"])                   # confidently wrong, unambiguous
        d.extra["refits"] = [{**refit[0], "chi2": 200.0}, {**refit[1], "chi2": 240.0}]
        return d

    monkeypatch.setattr(C, "simulate_campaign", fake_simulate)
    monkeypatch.setattr(C, "_diagnose", fake_diagnose)
    first = _stub(["spam_offset"], [{"effect": "dephasing", "named": ["dephasing"]}],
                  proposal)                          # the truth among the alternatives
    out = close_loop(JOB, first)
    rec = out["recommended"]
    assert seen[0] == [{"effects": ["spam_offset"], "forms": ["total"]},
                       {"effects": ["dephasing"], "forms": ["independent"]}]
    assert rec["n_steps"] == 1 and rec["status"] == "wrong" and rec["turned_wrong"]
    assert rec["separation_predicted"] == 27.0
    assert rec["separation_achieved"] == pytest.approx(30.0)      # |(240-200) - (110-100)|
    s = H.summarise([{**_record("dephasing", ["spam_offset"], alternatives=[]),
                      "closed_loop": out}])
    assert s["closed_loop"]["turned_wrong_recommended"] == 1
    assert s["closed_loop"]["separation_ratios"] == [pytest.approx(30.0 / 27.0)]
    # the binding direction assumed spam_offset; dephasing, the rival, was concealed: the
    # achieved separation is judged against the one expected if dephasing is true
    assert rec["premise_held"] is True and rec["separation_predicted_for_truth"] == 45.0
    assert s["closed_loop"]["separation_ratios_premise_held"] == [pytest.approx(30.0 / 45.0)]
    # a pair neither of which was concealed tests nothing
    job = {**JOB, "effects": {"motional_heating": {"ndot": 100.0}}}
    rec2 = close_loop(job, first)["recommended"]
    assert rec2["premise_held"] is False and "separation_predicted_for_truth" not in rec2
