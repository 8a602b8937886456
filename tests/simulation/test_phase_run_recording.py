"""The simulator's further phase run: taken after the recordings, it records the AOM's
phase transfer as it is then, changed only by the effects whose physics is the AOM's own
phase (the modulator's AM-to-PM the model's run did not have)."""

import dataclasses

import numpy as np
import pandas as pd
import pytest

from dpdfit.simulation import injections
from dpdfit.simulation.campaign.calibration_runs import calibration_runs
from dpdfit.simulation.further_recordings import extend_config
from tests.helpers.further_campaign import small_config

#: the effects whose physics moves the AOM's own phase transfer after the model's run
TOUCHES_PHASE_RUNS = {"am_pm_omitted"}
ONE_RUN = {"what": "phase_run", "settings": {"runs": 1}}


def _further_minus_model(cfg) -> np.ndarray:
    """The further phase run's phases minus the model's run's (rad, same amplitudes, the
    fitted window ``A >= 0.1``: below it a run reads mostly noise)."""
    _, ph, *_ = calibration_runs(extend_config(cfg, ONE_RUN))
    ph = ph[ph["A"] >= 0.1]
    runs = list(dict.fromkeys(ph["run"]))
    model = ph[ph["run"] == f"P{cfg.n_phase_runs:03d}"]["phase_rad"].to_numpy()
    return ph[ph["run"] == runs[-1]]["phase_rad"].to_numpy() - model


@pytest.mark.parametrize("name", sorted(injections.INJECTIONS))
def test_only_the_aoms_own_phase_changes_a_further_run(name):
    cfg = small_config()
    inj = injections.get(name)
    table = inj.harness_table()
    if not table:
        pytest.skip(f"{name}: the harness does not conceal it")
    plain = _further_minus_model(cfg)
    changed = False
    for form in table:
        v = inj.draw(np.random.default_rng(1), form)
        # the median change over the run, against 1e-3 rad of a run's own noise (the
        # harness's AM-to-PM is 0.05-0.15 rad at full drive): a drifted AOM changes the
        # weak beat's noise at the lowest amplitudes a little, not the phase
        changed |= bool(np.median(np.abs(_further_minus_model(cfg.inject({name: v}))
                                         - plain)) > 1e-3)
    assert changed == (name in TOUCHES_PHASE_RUNS)


def test_the_run_is_after_the_recordings_and_records_the_modulators_phase():
    cfg = dataclasses.replace(small_config(), n_phase_runs=3)
    _, ph, *_ = calibration_runs(extend_config(cfg, ONE_RUN))
    t = pd.to_datetime(ph.groupby("run", sort=False)["timestamp"].first(), utc=True)
    _, _, _, _, truth = calibration_runs(cfg)
    gates = (pd.Timestamp(cfg.start, tz="UTC") + pd.Timedelta(days=truth["gate_day"])
             + pd.Timedelta(hours=cfg.recording_hours[-1]))
    assert (t.iloc[:-1] < gates).all() and t.iloc[-1] > gates
    A = ph[(ph["run"] == t.index[-1]) & (ph["A"] >= 0.1)]["A"].to_numpy()
    plain = _further_minus_model(cfg)
    post = _further_minus_model(cfg.inject({"am_pm_omitted": {"dphi": 0.1}}))
    aom = _further_minus_model(cfg.inject({"am_pm_omitted": {"dphi_x": 0.1, "dphi_x4": 0.05}}))
    np.testing.assert_array_equal(post, plain)      # the beam path's phase: not the AOM's
    np.testing.assert_allclose(aom - plain, 0.1 * A ** 2 + 0.05 * A ** 4, rtol=0, atol=1e-12)
