"""The menu offers the detector linearity characterisation with its lab time; it decides a
detector nonlinearity against a stale table; a proposal of it is written as a schedule
and recorded by the simulator."""

import pytest

from dpdfit.analyses.diagnosis.fitting.hypothesis_fit import fit_hypothesis
from dpdfit.analyses.diagnosis.proposal.hypotheses import (LINEARITY_DRIVES, Hypothesis,
                                                           linearity_readings)
from dpdfit.analyses.diagnosis.proposal.menu import BUILDERS
from dpdfit.analyses.diagnosis.proposal.next_measurement import KINDS, describe_recording
from dpdfit.analyses.diagnosis.proposal.schedule import proposal_schedule
from dpdfit.core.defaults import LAB_TIMES, LINEARITY_POINTS
from dpdfit.errors import InputError
from dpdfit.recordings.schedule import check_schedule
from dpdfit.simulation.further_recordings import schedule_measurements
from dpdfit.simulation.recorded_schedule import record_further
from dpdfit.simulation.scheduled_points import check_recorded_as_scheduled
from tests.analyses.diagnosis.model.test_detector_linearity_fitted import (  # noqa: F401
    DET, STALE, det_case)


def test_offered_with_its_lab_time_and_separates_detector_from_stale(det_case):  # noqa: F811
    _, _, prob = det_case
    assert "detector_linearity" in KINDS
    det = Hypothesis(prob, fit_hypothesis(prob, DET))
    stale = Hypothesis(prob, fit_hypothesis(prob, STALE))
    items = [it for b in BUILDERS for it in b(prob, [det, stale], LAB_TIMES)]
    (item,) = [it for it in items if it.what == "detector_linearity"]
    assert item.settings["points"] == LINEARITY_POINTS == len(LINEARITY_DRIVES)
    assert item.seconds == pytest.approx(LAB_TIMES.attenuator_swap_s
                                         + 2 * LINEARITY_POINTS * LAB_TIMES.linearity_reading_s)
    assert 120 < item.seconds < 600          # a few minutes
    W = item.whitener(det, stale)
    d = W * (item.vector(det) - item.vector(stale))
    assert float(d @ d) > 100      # one characterisation tells them apart by > 10 sigma
    # a stale table predicts the linear ratio, the attenuator's transmission; the
    # detector a ratio falling towards full scale
    P = linearity_readings(prob)
    assert item.vector(stale) == pytest.approx(0.1 * P, rel=1e-12)
    ratio = item.vector(det) / (0.1 * P)
    assert ratio[-1] < ratio[0] - 0.05


def test_schedule_written_and_recorded(tmp_path):
    from tests.helpers.further_campaign import simulate, small_config
    camp = simulate(tmp_path / "c")
    proposal = {"what": "detector_linearity",
                "settings": {"points": 6, "attenuation_db": 10.0, "scans": 2},
                "lab_seconds": 2 * (60.0 + 12 * 5.0)}
    assert "attenuator" in describe_recording("detector_linearity", proposal["settings"])
    df = proposal_schedule(proposal, camp)
    assert list(df.columns)[-1] == "attenuation_db"
    assert len(df) == 12 and df["repeat"].tolist() == [1] * 6 + [2] * 6
    assert df["attenuation_db"].tolist() == [10.0] * 12
    assert df["lab_s"].sum() == pytest.approx(proposal["lab_seconds"])
    assert df["lab_s"].iloc[0] == pytest.approx(2 * 5.0 + 60.0 / 6)
    assert df["dpd"].isna().all() and df["shots"].isna().all()
    (m,) = schedule_measurements(df)
    assert m == {"what": "detector_linearity", "settings": {"points": 6, "scans": 2}}
    rec = record_further(small_config(), [m])
    assert len(rec.tables["detector_linearity"]) == 12
    check_recorded_as_scheduled(df, rec.tables)
    bad = df.copy()
    bad.loc[3, "attenuation_db"] = 0.0
    with pytest.raises(InputError, match="column 'attenuation_db', row 4"):
        check_schedule(bad, "s.csv")
    moved = df.copy()
    moved.loc[2, "A"] = 0.33
    with pytest.raises(InputError, match="cannot record this detector_linearity point"):
        check_recorded_as_scheduled(moved, rec.tables)
    # a schedule without such rows keeps its columns
    other = df.drop(columns="attenuation_db").assign(kind="amplitude_run")
    assert "attenuation_db" not in check_schedule(other, "s.csv").columns


def test_cheapest_decisive_when_the_spectra_are_slow():
    """The bundled campaign, a stale table against a detector nonlinearity, a lab whose
    spectra take a month: the linearity check (minutes) is proposed, decisive, before
    two calibration runs (which the same lab without an attenuator is sent to,
    tests/analyses/diagnosis/proposal/test_next_measurement.py)."""
    from dpdfit.analyses.diagnosis.model.residuals import Problem
    from dpdfit.analyses.diagnosis.observables.campaign import load_campaign
    from dpdfit.analyses.diagnosis.proposal.next_measurement import propose_next_measurement
    from dpdfit.core.defaults import LabTimes
    from tests.analyses.diagnosis.proposal import test_next_measurement as T
    prob = Problem(load_campaign(T.BUNDLED_CAMPAIGN), with_gates=False)
    nm = propose_next_measurement(prob, [T._stale((4.0,)), T.DETECTOR],
                                  lab=LabTimes(spectrum_trace_s=30 * 86400.0))
    assert nm.what == "detector_linearity"
    assert nm.to_dict()["decisive"] and nm.lab_seconds < 600
