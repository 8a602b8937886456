"""The menu offers the AOM pulse response with the spectra, with its lab time; it separates
a memory from a higher-order nonlinearity; a proposal of it is written as a schedule and
recorded by the simulator."""

import numpy as np
import pytest

from dpdfit.analyses.diagnosis.fitting.hypothesis_fit import fit_hypothesis
from dpdfit.analyses.diagnosis.proposal.hypotheses import Hypothesis, pulse_amplitude
from dpdfit.analyses.diagnosis.proposal.menu import (BUILDERS, PULSE_REL_NOISE,
                                                     pulse_relative_noise)
from dpdfit.analyses.diagnosis.proposal.next_measurement import (KINDS, describe_recording,
                                                                 propose_next_measurement)
from dpdfit.analyses.diagnosis.proposal.schedule import proposal_schedule
from dpdfit.core.defaults import LAB_TIMES
from dpdfit.errors import InputError
from dpdfit.recordings.schedule import check_schedule
from dpdfit.simulation.further_recordings import schedule_measurements
from dpdfit.simulation.recorded_schedule import record_further
from dpdfit.simulation.scheduled_points import check_recorded_as_scheduled
from tests.analyses.diagnosis.model.test_pulse_fitted import memory_case  # noqa: F401


def test_offered_with_spectra_and_separates_memory_from_higher_order(memory_case):  # noqa: F811
    """On the campaign without a trace: one pulse response, a minute of lab time, tells a
    slow memory from a higher-order nonlinearity by far more than 3 sigma."""
    cfg, with_pulse, prob = memory_case
    assert "pulse_response" in KINDS
    mem = Hypothesis(prob, fit_hypothesis(prob, (("aom_memory", "slow"),)))
    him = Hypothesis(prob, fit_hypothesis(prob, (("higher_order_im", None),)))
    items = [it for b in BUILDERS for it in b(prob, [mem, him], LAB_TIMES)]
    (item,) = [it for it in items if it.what == "pulse_response"]
    assert item.seconds == LAB_TIMES.pulse_trace_s == 60.0
    assert item.settings == {"A": cfg.time_scan_A} == {"A": pulse_amplitude(prob.camp)}
    d = item.whitener(mem, him) * (item.vector(mem) - item.vector(him))
    assert float(d @ d) > 100
    assert np.allclose(item.vector(him), 1.0)           # no memory: a clean step
    # the campaign's own trace gives the noise; without one the simulator's photodiode
    assert pulse_relative_noise(prob.camp) == PULSE_REL_NOISE
    assert pulse_relative_noise(with_pulse.camp) == pytest.approx(PULSE_REL_NOISE, rel=0.2)
    # the proposal: the cheapest decisive recording of the menu is the pulse response
    proposal = propose_next_measurement(prob, [mem.fit, him.fit]).to_dict()
    assert proposal["what"] == "pulse_response" and proposal["lab_seconds"] == 60.0


def test_the_menus_trace_is_the_simulators():
    from dpdfit.analyses.diagnosis.proposal.hypotheses import PULSE_TIMES_US
    from dpdfit.simulation.campaign.pulse_runs import PULSE_TIMES_US as RECORDED
    assert np.array_equal(PULSE_TIMES_US, RECORDED)


def test_offered_only_with_a_tone_model():
    class NoTones:
        tone = None
    built = [it for b in BUILDERS for it in b(NoTones(), [], LAB_TIMES)
             if b.__name__ == "_pulse_response"]
    assert not built


def test_schedule_written_and_recorded(tmp_path):
    from tests.helpers.further_campaign import simulate, small_config
    camp = simulate(tmp_path / "c")
    proposal = {"what": "pulse_response", "settings": {"A": 0.4, "scans": 2},
                "lab_seconds": 120.0}
    assert "pulse response" in describe_recording("pulse_response", proposal["settings"])
    df = proposal_schedule(proposal, camp)
    assert df["kind"].tolist() == ["pulse_response"] * 2
    assert df["repeat"].tolist() == [1, 2] and df["point"].tolist() == [0, 0]
    assert df["A"].tolist() == [0.4, 0.4] and df["shots"].isna().all()
    assert df["lab_s"].sum() == pytest.approx(120.0)
    assert "prepared" not in df.columns
    (m,) = schedule_measurements(df)
    assert m == {"what": "pulse_response", "settings": {"A": 0.4, "scans": 2}}
    rec = record_further(small_config(), [m])
    assert rec.tables["pulse_response"]["run"].unique().tolist() == ["pulse1", "pulse2"]
    check_recorded_as_scheduled(df, rec.tables)
    bad = df.copy()
    bad.loc[1, "A"] = 0.0
    with pytest.raises(InputError, match="column 'A', row 2"):
        check_schedule(bad, "s.csv")
    moved = df.copy()
    moved.loc[1, "A"] = 0.5
    with pytest.raises(InputError, match="pulse_response point"):
        check_recorded_as_scheduled(moved, rec.tables, "s.csv")
