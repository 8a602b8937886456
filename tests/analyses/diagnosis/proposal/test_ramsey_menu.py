"""The menu offers the Ramsey and spin-echo scan when the campaign has gate scans, with its
lab time; a proposal of it is written as a schedule and recorded by the simulator."""

import numpy as np
import pytest

from dpdfit.analyses.diagnosis.fitting.hypothesis_fit import fit_hypothesis
from dpdfit.analyses.diagnosis.proposal.hypotheses import Hypothesis
from dpdfit.analyses.diagnosis.proposal.menu import BUILDERS, RAMSEY_SHOTS, ramsey_seconds
from dpdfit.analyses.diagnosis.proposal.next_measurement import KINDS, describe_recording
from dpdfit.analyses.diagnosis.proposal.schedule import proposal_schedule
from dpdfit.core.defaults import LAB_TIMES
from dpdfit.errors import InputError
from dpdfit.recordings.schedule import check_schedule
from dpdfit.simulation.further_recordings import schedule_measurements
from dpdfit.simulation.recorded_schedule import difference_rows, record_further
from dpdfit.simulation.scheduled_points import check_recorded_as_scheduled
from tests.analyses.diagnosis.model.test_ramsey_fitted import common_case  # noqa: F401


def test_offered_with_gate_scans_and_separates_dephasing_from_heating(common_case):  # noqa: F811
    _, _, prob = common_case                     # the campaign without ramsey.csv
    assert "ramsey" in KINDS
    base = fit_hypothesis(prob, ())
    tone = {k: v for k, v in base.nuisances.items() if prob.is_tone_key(k)}
    deph = Hypothesis(prob, fit_hypothesis(prob, (("dephasing", "common"),), fixed=tone))
    heat = Hypothesis(prob, fit_hypothesis(prob, (("motional_heating", None),), fixed=tone))
    items = [it for b in BUILDERS for it in b(prob, [deph, heat], LAB_TIMES)]
    (item,) = [it for it in items if it.what == "ramsey"]
    assert item.settings["shots"] == RAMSEY_SHOTS and item.settings["points"] == 20
    # 20 waits to 75 ms x 2 sequences x 200 shots: a couple of minutes
    assert item.seconds == pytest.approx(ramsey_seconds(0.05, RAMSEY_SHOTS, LAB_TIMES))
    assert 60 < item.seconds < 300
    W = item.whitener(deph, heat)
    d = W @ (item.vector(deph) - item.vector(heat))
    assert float(d @ d) > 25         # one scan tells them apart by > 5 sigma


def test_offered_only_with_gates():
    class NoGates:
        gate = None
    assert not [it for b in BUILDERS[-1:] for it in b(NoGates(), [], LAB_TIMES)]


def test_schedule_written_and_recorded(tmp_path):
    from tests.helpers.further_campaign import simulate, small_config
    camp = simulate(tmp_path / "c")
    st = {"shots": 150, "points": 20, "max_wait_us": 75000.0, "scans": 2}
    proposal = {"what": "ramsey", "settings": st, "lab_seconds": 240.0}
    assert "Ramsey" in describe_recording("ramsey", st)
    df = proposal_schedule(proposal, camp)
    assert len(df) == 2 * 2 * 20
    assert df["sequence"].tolist()[:21] == ["ramsey"] * 20 + ["echo"]
    assert (df["A"] == 0).all() and (df["shots"] == 150).all()
    assert df["wait_us"].max() == pytest.approx(75000.0) and df["wait_us"].min() == 0
    assert df["lab_s"].sum() == pytest.approx(240.0)
    # a row's share grows with its wait
    one = df[df["repeat"] == 1]
    assert np.all(np.diff(one["lab_s"].to_numpy()[:20]) >= 0)
    (m,) = schedule_measurements(df)
    assert m == {"what": "ramsey", "settings": {"shots": 150, "scans": 2}}
    cfg = small_config()
    rec = record_further(cfg, [m])
    assert list(rec.tables) == ["ramsey"]
    assert len(rec.tables["ramsey"]) == 80
    check_recorded_as_scheduled(df, rec.tables)
    long = difference_rows(cfg, [m], include_spectra=False, include_gates=False)
    assert rec.tables["ramsey"].equals(long["ramsey"])
    bad = df.copy()
    bad.loc[1, "sequence"] = "cpmg"
    with pytest.raises(InputError, match="column 'sequence', row 2"):
        check_schedule(bad, "s.csv")
    bad = df.copy()
    bad.loc[2, "wait_us"] = -1.0
    with pytest.raises(InputError, match="column 'wait_us', row 3"):
        check_schedule(bad, "s.csv")
    # a schedule without ramsey rows keeps its columns
    assert "sequence" not in check_schedule(df[df["kind"] != "ramsey"].drop(
        columns=["sequence", "wait_us"]), "s.csv").columns
