"""The menu offers the SPAM characterisation when the campaign has gate scans, with its lab
time; a proposal of it is written as a schedule and recorded by the simulator."""

import pytest

from dpdfit.analyses.diagnosis.fitting.hypothesis_fit import fit_hypothesis
from dpdfit.analyses.diagnosis.proposal.hypotheses import Hypothesis
from dpdfit.analyses.diagnosis.proposal.menu import BUILDERS, SPAM_SHOTS
from dpdfit.analyses.diagnosis.proposal.next_measurement import KINDS, describe_recording
from dpdfit.analyses.diagnosis.proposal.schedule import proposal_schedule
from dpdfit.core.defaults import LAB_TIMES
from dpdfit.errors import InputError
from dpdfit.recordings.schedule import check_schedule
from dpdfit.simulation.further_recordings import schedule_measurements
from dpdfit.simulation.recorded_schedule import record_further
from dpdfit.simulation.scheduled_points import check_recorded_as_scheduled
from tests.analyses.diagnosis.model.test_spam_fitted import spam_case  # noqa: F401


def test_offered_with_gate_scans_and_separates_spam_from_heating(spam_case):  # noqa: F811
    cfg, prob = spam_case
    assert "spam" in KINDS
    base = fit_hypothesis(prob, ())
    tone = {k: v for k, v in base.nuisances.items() if prob.is_tone_key(k)}
    spam = Hypothesis(prob, fit_hypothesis(prob, (("spam_offset", "total"),), fixed=tone))
    heat = Hypothesis(prob, fit_hypothesis(prob, (("motional_heating", None),), fixed=tone))
    items = [it for b in BUILDERS for it in b(prob, [spam, heat], LAB_TIMES)]
    (item,) = [it for it in items if it.what == "spam"]
    assert item.seconds == pytest.approx(2 * SPAM_SHOTS * LAB_TIMES.spam_shot_s)
    assert item.seconds < 60
    W = item.whitener(spam, heat)
    d = W @ (item.vector(spam) - item.vector(heat))
    assert float(d @ d) > 9          # one SPAM recording tells them apart by > 3 sigma


def test_offered_only_with_gates():
    class NoGates:
        gate = None
    assert not [it for b in BUILDERS[-1:] for it in b(NoGates(), [], LAB_TIMES)]


def test_schedule_written_and_recorded(tmp_path):
    from tests.helpers.further_campaign import simulate
    camp = simulate(tmp_path / "c")
    proposal = {"what": "spam", "settings": {"shots": 500, "states": ["00", "11"], "scans": 2},
                "lab_seconds": 4.0}
    assert "SPAM" in describe_recording("spam", proposal["settings"])
    df = proposal_schedule(proposal, camp)
    assert df["prepared"].tolist() == ["00", "11", "00", "11"]
    assert df["A"].tolist() == [0.0] * 4 and df["shots"].tolist() == [500] * 4
    assert df["lab_s"].sum() == pytest.approx(4.0)
    (m,) = schedule_measurements(df)
    assert m == {"what": "spam", "settings": {"shots": 500, "scans": 2}}
    from tests.helpers.further_campaign import small_config
    rec = record_further(small_config(), [m])
    assert rec.tables["spam"]["prepared"].tolist() == ["00", "11", "00", "11"]
    check_recorded_as_scheduled(df, rec.tables)
    bad = df.copy()
    bad.loc[1, "prepared"] = "12"
    with pytest.raises(InputError, match="column 'prepared', row 2"):
        check_schedule(bad, "s.csv")
    # a schedule without spam rows keeps its columns
    assert "prepared" not in check_schedule(df[df["kind"] != "spam"].drop(
        columns="prepared"), "s.csv").columns
