"""The gate engine and the diagnosis size their large arrays before making them.

A state too large for the memory limit (:mod:`dpdfit.core.memory`) is refused
with one :class:`~dpdfit.errors.InputError` line instead of a traceback or a
MemoryError: the engine's own check (any caller), the diagnosis's check before
its parallel runs (naming the setting and the campaign), the deviation search's.
Cheap: the refused states are never allocated, and the limit is lowered where
a normal size must be refused.
"""

import math
import shutil

import numpy as np
import pandas as pd
import pytest

from dpdfit.analyses.diagnosis.model.gates.engine_runs import check_runs_fit
from dpdfit.analyses.diagnosis.evidence.deviations import deviating_intervals
from dpdfit.core import memory
from dpdfit.errors import InputError
from dpdfit.models import gate_sim
from dpdfit.models.gate_sim.fock import fock_cutoff, thermal_levels
from tests.helpers.cli_refusal import assert_refused
from tests.helpers.paths import ROOT

CAMP = ROOT / "datasets" / "synthetic_campaign"

# a Cardioid(1,2)-like drive calibrated to a 3.4 kHz gate rate, with a weak
# intermodulation tone on the sideband (n = 0) that displaces the mode without bound
B_T = np.array([0.02, 0.5, 0.5])
C_T = np.array([0.02, 0.5, 0.5])
N_T = np.array([0, 1, 2])
XI0 = 3.4e3
EO = XI0 / gate_sim.calibrate_xi0(B_T, C_T, N_T, 1.0)


def test_engine_size_is_the_size_the_integration_uses():
    for lindblad in (True, False):
        evolve = gate_sim.evolve_lindblad if lindblad else gate_sim.evolve
        _, info = evolve(B_T, C_T, N_T, EO, XI0, [1 / XI0], 0.1, return_info=True)
        size = gate_sim.engine_size(B_T, C_T, N_T, EO, XI0, 1 / XI0, 0.1, lindblad=lindblad)
        assert size.n_fock == info["n_fock"] and size.n_thermal == info["m_max"] + 1
        assert size.nbytes < 1e8


def test_thermal_levels_without_making_them():
    for nbar in (0.0, 0.1, 1.0, 7.3):
        for tail in (gate_sim.THERMAL_TAIL, 1e-6):
            assert thermal_levels(nbar, tail) == gate_sim.thermal_weights(nbar, tail).size
    assert thermal_levels(1e12) > 1e13 and thermal_levels(1e20) == 10 ** 18
    assert fock_cutoff(0.1, math.inf) == 10 ** 18


def test_a_time_a_thousand_gates_long_is_refused_before_allocation():
    with pytest.raises(InputError) as exc:
        gate_sim.evolve_lindblad(B_T, C_T, N_T, EO, XI0, [1 / XI0, 1000 / XI0], 0.1,
                                 T2=0.05, ndot=5.0)
    msg = str(exc.value)
    assert msg.startswith("the gate simulation (master equation on 4 spin states x ")
    assert "GB of memory, above the limit of" in msg and "in the wrong unit?" in msg
    assert "\n" not in msg


def test_a_huge_nbar_is_refused_before_the_thermal_weights_are_made():
    with pytest.raises(InputError, match=r"Schrodinger equation on 4 spin states x \d+ Fock "
                                         r"levels x \d+ thermal levels\) needs about"):
        gate_sim.evolve(B_T, C_T, N_T, EO, XI0, 1 / XI0, 1e9)


def test_the_limit_applies_to_every_engine_run(monkeypatch):
    monkeypatch.setenv(memory.MEMORY_ENV, "1e-6")
    with pytest.raises(InputError, match="DPDFIT_MAX_MEMORY_GB"):
        gate_sim.setting_branches(B_T, C_T, N_T, EO, XI0)


def test_the_diagnosis_names_the_setting_and_the_runs_at_once(monkeypatch, tmp_path):
    calls = [((B_T, C_T, N_T, EO, XI0), dict(nbar=0.1, T2=0.05, ndot=5.0,
                                             scan_times=[1.2 / XI0]))] * 3
    check_runs_fit(calls, [(0.5, 0)] * 3, tmp_path)
    monkeypatch.setenv(memory.MEMORY_ENV, "1e-6")
    monkeypatch.setattr("dpdfit.analyses.diagnosis.model.gates.engine_runs.n_workers", lambda: 2)
    with pytest.raises(InputError) as exc:
        check_runs_fit(calls, [(0.5, 0), (0.6, 1), (0.7, 0)], tmp_path)
    msg = str(exc.value)
    assert msg.startswith(f"{tmp_path}: the gate simulation of setting A=0.5, dpd=0 (master "
                          "equation on 4 spin states x ")
    assert "2 runs at once) needs about" in msg and "time_scans.csv t_us" in msg


def test_deviation_search_refuses_a_series_too_large_for_memory(monkeypatch):
    x = np.arange(200.0)
    assert deviating_intervals(x, np.zeros(200)) == []
    monkeypatch.setenv(memory.MEMORY_ENV, "1e-4")     # 100 kB < 20100 intervals x 96 B
    with pytest.raises(InputError, match="the deviation search of a residual series of 200 "
                                         "points needs about 0.00191 GB"):
        deviating_intervals(x, np.zeros(200))


def test_time_scans_in_the_wrong_unit_reach_the_guard_from_the_command_line(tmp_path, capsys):
    """Gate rates plausible, time scans 1000x too long: the size guard, not the readers."""
    folder = tmp_path / "campaign"
    folder.mkdir()
    for p in CAMP.iterdir():
        if p.is_file():
            shutil.copy(p, folder / p.name)
    ts = pd.read_csv(folder / "time_scans.csv", comment="#")
    ts["t_us"] *= 1000
    ts.to_csv(folder / "time_scans.csv", index=False)
    plots = tmp_path / "plots"
    assert_refused(capsys, ["diagnose", folder, "--plot", plots],
                   [f"{folder}: the gate simulation of setting A=", "Fock levels",
                    "GB of memory, above the limit", "time_scans.csv t_us"],
                   [folder / "time_scans.csv"])
    assert not plots.exists()
