"""The menu offers the sideband thermometry when the campaign has gate scans, with its lab
time (the shots' own and their waits); a proposal of it is written as a schedule and
recorded by the simulator."""

import pytest

from dpdfit.analyses.diagnosis.fitting.hypothesis_fit import fit_hypothesis
from dpdfit.analyses.diagnosis.proposal.hypotheses import Hypothesis
from dpdfit.analyses.diagnosis.proposal.menu import BUILDERS, THERMOMETRY_SHOTS
from dpdfit.analyses.diagnosis.proposal.next_measurement import KINDS, describe_recording
from dpdfit.analyses.diagnosis.proposal.schedule import proposal_schedule
from dpdfit.core.defaults import LAB_TIMES
from dpdfit.errors import InputError
from dpdfit.models.sideband_thermometry import THERMOMETRY_WAITS_US
from dpdfit.recordings.schedule import check_schedule
from dpdfit.simulation.further_recordings import schedule_measurements
from dpdfit.simulation.recorded_schedule import record_further
from dpdfit.simulation.scheduled_points import check_recorded_as_scheduled
from tests.analyses.diagnosis.model.test_thermometry_fitted import heating_case  # noqa: F401


def test_offered_with_gate_scans_and_separates_heating_from_dephasing(heating_case):  # noqa: F811
    cfg, prob = heating_case
    assert "thermometry" in KINDS
    base = fit_hypothesis(prob, ())
    tone = {k: v for k, v in base.nuisances.items() if prob.is_tone_key(k)}
    heat = Hypothesis(prob, fit_hypothesis(prob, (("motional_heating", "during"),),
                                           fixed=tone))
    deph = Hypothesis(prob, fit_hypothesis(prob, (("dephasing", None),), fixed=tone))
    items = [it for b in BUILDERS for it in b(prob, [heat, deph], LAB_TIMES)]
    (item,) = [it for it in items if it.what == "thermometry"]
    waits_s = sum(THERMOMETRY_WAITS_US) * 1e-6
    want = 2 * THERMOMETRY_SHOTS * (len(THERMOMETRY_WAITS_US) * LAB_TIMES.thermometry_shot_s
                                    + waits_s)
    assert item.seconds == pytest.approx(want)
    assert item.seconds < 60                     # a characterisation of seconds, not hours
    W = item.whitener(heat, deph)
    d = W * (item.vector(heat) - item.vector(deph))
    assert float(d @ d) > 9          # one thermometry tells them apart by > 3 sigma


def test_offered_only_with_gates():
    class NoGates:
        gate = None
    assert not [it for b in BUILDERS for it in b(NoGates(), [], LAB_TIMES)
                if it.what == "thermometry"]


def test_schedule_written_and_recorded(tmp_path):
    from tests.helpers.further_campaign import simulate, small_config
    camp = simulate(tmp_path / "c")
    st = {"shots": 100, "waits_us": list(THERMOMETRY_WAITS_US), "sidebands": ["red", "blue"],
          "scans": 2}
    proposal = {"what": "thermometry", "settings": st, "lab_seconds": 20.0}
    assert "thermometry" in describe_recording("thermometry", st)
    df = proposal_schedule(proposal, camp)
    n = 2 * len(THERMOMETRY_WAITS_US)
    assert len(df) == 2 * n and list(df.columns[-2:]) == ["wait_us", "sideband"]
    assert df["sideband"].tolist()[:2] == ["red", "blue"]
    assert df["A"].tolist() == [0.0] * (2 * n) and (df["shots"] == 100).all()
    assert df["lab_s"].sum() == pytest.approx(20.0)
    # a row's lab time grows with its wait
    assert df["lab_s"].iloc[n - 1] > df["lab_s"].iloc[0]
    (m,) = schedule_measurements(df)
    assert m == {"what": "thermometry", "settings": {"shots": 100, "scans": 2}}
    rec = record_further(small_config(), [m])
    assert len(rec.tables["thermometry"]) == 2 * n
    check_recorded_as_scheduled(df, rec.tables)
    edited = df.copy()
    edited.loc[0, "wait_us"] = 123.0
    with pytest.raises(InputError, match="thermometry point"):
        check_recorded_as_scheduled(edited, rec.tables)
    for col, value, words in (("sideband", "green", "does not exist"),
                              ("wait_us", -5.0, "must be >= 0")):
        bad = df.copy()
        bad.loc[1, col] = value
        with pytest.raises(InputError, match=f"column '{col}', row 2") as err:
            check_schedule(bad, "s.csv")
        assert words in str(err.value) and "\n" not in str(err.value)
    # a schedule without thermometry rows keeps its columns
    plain = check_schedule(df[df["kind"] != "thermometry"].drop(columns=["wait_us",
                                                                          "sideband"]), "s.csv")
    assert "wait_us" not in plain.columns
