"""The ARTIQ experiment the docs show records what its import mapping reads.

ARTIQ is not installable here, so ``examples/schedule/scheduled_recording.py`` runs
against a stand-in of ``artiq.experiment`` (arguments at their defaults,
``set_dataset`` kept), with the lab's ``measure_*`` methods replaced by counts drawn
at random; its datasets are written as a results file, and
``examples/schedule/scheduled_recording.toml`` must import exactly the points of the
schedule, with the counts measured for them.
"""

from __future__ import annotations

import importlib.util
import json
import shutil
import sys
import types

import numpy as np
import pandas as pd
import pytest

from dpdfit.analyses.diagnosis.proposal.schedule import proposal_schedule
from dpdfit.recordings.campaign_import import import_campaign
from dpdfit.recordings.schedule import write_schedule
from tests.helpers.bundled_data import CAMPAIGN
from tests.helpers.paths import ROOT

pytest.importorskip("h5py")

EXAMPLE = ROOT / "examples" / "schedule"
PROPOSALS = [
    {"what": "populations", "settings": {"A": 0.5, "dpd": 1, "shots": 625, "scans": 3}},
    {"what": "parity", "settings": {"A": 0.6, "dpd": 0, "shots": 10000, "scans": 2}},
    {"what": "time_scan", "settings": {"A": 0.5, "dpd": 1, "shots": 625, "points": 24,
                                       "scans": 2}},
    {"what": "amplitude_run", "settings": {"runs": 2}},
    {"what": "spam", "settings": {"shots": 800, "states": ["00", "11"], "scans": 2}},
    {"what": "thermometry", "settings": {"shots": 200, "waits_us": [0.0, 500.0, 2000.0],
                                         "sidebands": ["red", "blue"]}},
]
CLASSES = {"populations": "ScheduledPopulations", "parity": "ScheduledParity",
           "time_scan": "ScheduledTimeScan", "amplitude_run": "ScheduledAmplitudeRun",
           "spam": "ScheduledSpam", "thermometry": "ScheduledThermometry"}
TABLES = {"populations": "populations", "parity": "parity", "time_scan": "time_scans",
          "amplitude_run": "calibration_amplitude", "spam": "spam",
          "thermometry": "thermometry"}


def _artiq_stand_in():
    """``artiq.experiment`` with what the example uses: arguments take their defaults."""
    class StringValue:
        def __init__(self, default):
            self.default = default

    class EnvExperiment:
        def __init__(self, arguments=None):
            self._arguments, self.datasets = dict(arguments or {}), {}
            self.build()

        def setattr_device(self, name):
            setattr(self, name, None)

        def setattr_argument(self, name, proc):
            setattr(self, name, self._arguments.get(name, proc.default))

        def set_dataset(self, key, value, archive=True):
            self.datasets[key] = value

    mod = types.ModuleType("artiq.experiment")
    mod.EnvExperiment, mod.StringValue = EnvExperiment, StringValue
    return mod


@pytest.fixture(scope="module")
def example():
    saved = {k: sys.modules.get(k) for k in ("artiq", "artiq.experiment")}
    sys.modules["artiq"] = types.ModuleType("artiq")
    sys.modules["artiq.experiment"] = _artiq_stand_in()
    try:
        spec = importlib.util.spec_from_file_location("scheduled_recording",
                                                      EXAMPLE / "scheduled_recording.py")
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
    finally:
        for k, v in saved.items():
            if v is None:
                sys.modules.pop(k, None)
            else:
                sys.modules[k] = v
    return mod


def _lab(cls, rng):
    """The example's experiment with the lab's sequences replaced by random counts."""
    class Lab(cls):
        def _three(self, shots):
            return tuple(int(x) for x in rng.multinomial(shots, [0.48, 0.04, 0.48]))

        def measure_populations(self, A, dpd, shots):
            return self._three(shots)

        def measure_populations_at(self, A, dpd, shots, t_us):
            return self._three(shots)

        def measure_parity(self, A, dpd, shots, phase_rad):
            return int(rng.binomial(shots, 0.5 + 0.45 * np.cos(2 * phase_rad)))

        def measure_prepared(self, state, shots):
            return self._three(shots)

        def measure_sideband(self, wait_us, sideband, shots):
            return int(rng.binomial(shots, 0.8 if sideband == "red" else 0.1))

        def measure_power(self, A):
            return float(A ** 2 + 1e-3 * rng.standard_normal()), 1e-3
    return Lab


def test_experiment_records_what_the_mapping_imports(example, tmp_path):
    from dpdfit.simulation.artiq_results_file import write_results_file
    rng = np.random.default_rng(41)
    frames = [proposal_schedule(p, CAMPAIGN) for p in PROPOSALS]
    sched = tmp_path / "schedule.csv"
    write_schedule(pd.concat(frames, ignore_index=True), sched)
    lab = tmp_path / "lab"
    lab.mkdir()
    text = (EXAMPLE / "scheduled_recording.toml").read_text()
    (lab / "mapping.toml").write_text(text)
    recorded, rid, t0 = {}, 1000, 1.77e9
    for what, frame in zip(CLASSES, frames):
        repeats = [str(r) for r in sorted(frame["repeat"].unique())] \
            if what == "amplitude_run" else [None]
        for rep in repeats:
            args = {"schedule": str(sched), **({"repeat": rep} if rep else {})}
            exp = _lab(getattr(example, CLASSES[what]), rng)(args)
            exp.prepare()
            exp.run()
            write_results_file(lab, rid, CLASSES[what], t0 + rid, exp.datasets)
            recorded.setdefault(what, []).append((rid, exp.datasets))
            rid += 1
    imported = import_campaign(lab / "mapping.toml", progress=False)
    for what, frame in zip(CLASSES, frames):
        df = imported.tables[TABLES[what]]
        assert len(df) == len(frame), what                     # every point, once
        if what == "spam":                 # the prepared states as the schedule names them
            [(_, ds)] = recorded[what]
            assert df["prepared"].tolist() == frame["prepared"].tolist() == ["00", "11"] * 2
            for col in ("n00", "n01_10", "n11", "shots"):
                np.testing.assert_array_equal(df[col].to_numpy(float), np.asarray(ds[col]))
            continue
        if what == "thermometry":          # the waits and sidebands as the schedule names them
            [(_, ds)] = recorded[what]
            assert df["sideband"].tolist() == frame["sideband"].tolist() == ["red", "blue"] * 3
            np.testing.assert_array_equal(df["wait_us"].to_numpy(float),
                                          frame["wait_us"].to_numpy(float))
            for col in ("n_bright", "shots"):
                np.testing.assert_array_equal(df[col].to_numpy(float), np.asarray(ds[col]))
            continue
        np.testing.assert_array_equal(df["A"].to_numpy(float), frame["A"].to_numpy(float))
        if what == "amplitude_run":
            assert sorted(df["run"].unique()) == ["R1003", "R1004"]
            got = np.concatenate([d["power"] for _, d in recorded[what]])
            np.testing.assert_array_equal(df["power"].to_numpy(float), got)
            continue
        [(_, ds)] = recorded[what]
        np.testing.assert_array_equal(df["dpd"].to_numpy(float), frame["dpd"].to_numpy(float))
        np.testing.assert_array_equal(df["shots"].to_numpy(float),
                                      frame["shots"].to_numpy(float))
        for col in ("n00", "n11", "n_even", "phase_rad", "t_us"):
            if col in ds:
                np.testing.assert_array_equal(df[col].to_numpy(float), np.asarray(ds[col]))
        if what != "time_scan":
            np.testing.assert_array_equal(df["scan"].to_numpy(float),
                                          frame["repeat"].to_numpy(float))
    meta = json.loads(json.dumps(imported.meta))
    camp = json.loads((CAMPAIGN / "campaign.json").read_text())
    # the mapping's constants are the bundled campaign's (dpdfit add compares them)
    for k in ("nu_hz", "eta_ld", "parity_phases"):
        assert meta[k] == camp[k]
    assert meta["predistortion_table"]["amplitude_run"] == \
        camp["predistortion_table"]["amplitude_run"]
    shutil.rmtree(lab)
