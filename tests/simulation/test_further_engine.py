"""The further recordings' engine: many scans of one setting share the engine's work,
and what they draw from is the exact engine's law (interpolated far below its tolerance)."""

from __future__ import annotations

import numpy as np
import pytest

from dpdfit.simulation.campaign import further_engine as FE
from dpdfit.simulation.campaign.further_engine import FurtherEngine
from dpdfit.models import gate_sim
from dpdfit.core.defaults import ERROR_MODEL

PHASES = ERROR_MODEL.analysis_phases()
SIGMA_DB = 0.1


def _tones():
    # a Cardioid(1,2)-like pair of tones per sideband, as the engine's tests drive it
    n = np.array([1, 2])
    b = np.array([1.0, 0.5]) + 0j
    return n, b, b.copy()


@pytest.fixture(scope="module")
def exact_run():
    n, b, c = _tones()
    eO = 2 * np.pi * 40e3
    xi = gate_sim.calibrate_xi0(b, c, n, eO)
    calls = []

    def run(A, d, eps_db, scan_times=None):
        calls.append(eps_db)
        return gate_sim.simulate_setting(b, c, n, eO, xi, parity_phases=PHASES, nbar=0.1,
                                         T2=0.05, ndot=5.0, p_prep=0.003, p_det=1e-4,
                                         power_error_db=eps_db, scan_times=scan_times)
    run.calls = calls
    return run


def test_few_scans_run_the_engine_exactly(exact_run):
    eng = FurtherEngine({(0.6, 1): FE.INTERPOLATE_ABOVE}, SIGMA_DB, exact_run)
    before = len(exact_run.calls)
    r = eng.scan(0.6, 1, 0.03)
    assert exact_run.calls[before:] == [0.03]
    assert np.isfinite(r.fidelity)


def test_many_scans_draw_from_the_exact_law(exact_run):
    eng = FurtherEngine({(0.6, 1): 300}, SIGMA_DB, exact_run)
    before = len(exact_run.calls)
    rng = np.random.default_rng(5)
    eps = SIGMA_DB * rng.standard_normal(300)
    outs = [eng.scan(0.6, 1, e) for e in eps]
    # 300 scans cost the nodes only (no draw here is beyond six sigma)
    assert len(exact_run.calls) - before == FE.CHEBYSHEV_NODES
    for e, r in zip(eps[:4], outs[:4]):
        x = exact_run(0.6, 1, e)
        # far below the engine's own integration error (~1e-9) and any shot noise
        assert np.max(np.abs(r.pop - x.pop)) < 1e-9
        assert np.max(np.abs(r.parity_probs - x.parity_probs)) < 1e-9
        assert r.parity_probs.shape == x.parity_probs.shape
        assert np.isnan(r.fidelity)            # a node's state is not this scan's
    # beyond the span the engine runs exactly
    far = FE.JITTER_SPAN * SIGMA_DB * 1.5
    n = len(exact_run.calls)
    eng.scan(0.6, 1, far)
    assert exact_run.calls[n:] == [far]


def test_repeated_time_scans_run_once(exact_run):
    eng = FurtherEngine({}, SIGMA_DB, exact_run)
    t = np.linspace(0, 3e-4, 5)
    n = len(exact_run.calls)
    a = eng.time_scan(0.6, 1, 3.4e3, t)
    b = eng.time_scan(0.6, 1, 3.4e3, t)
    assert a is b and len(exact_run.calls) - n == 1
    eng.time_scan(0.6, 1, 3.4e3, t[:4])               # another grid: another run
    assert len(exact_run.calls) - n == 2


def test_counts_of_further_scans_per_setting():
    further = (("scan", 0.6, 1, 625, 0), ("amplitude_run",), ("scan", 0.6, 1, 0, 40),
               ("time_scan", 0.6, 1, 625, 13), ("scan", 0.5, 0, 625, 0))
    assert FE.jittered_scan_counts(further) == {(0.6, 1): 2, (0.5, 0): 1}
