"""The next measurement a diagnosis proposes when it cannot decide between hypotheses.

Hypotheses are :class:`FitResult` objects made by hand (parameter sets at chosen
values), so that the expected separations are known; the tone side runs on the
bundled campaign without its gates (about a second), the gate side on a stub gate
model.
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from dpdfit.analyses.diagnosis.fitting import FitResult
from dpdfit.analyses.diagnosis.next_measurement import (KINDS, NextMeasurement,
                                                        decisive_target,
                                                        propose_next_measurement)
from dpdfit.core.defaults import ERROR_MODEL, LAB_TIMES, LabTimes

BUNDLED_CAMPAIGN = Path(__file__).resolve().parents[1] / "datasets" / "synthetic_campaign"
CONTRACT_KEYS = {"what", "settings", "expected_delta_bic", "separates", "lab_seconds",
                 "per_hour", "menu", "decisive"}
GATE_KINDS = {"populations", "parity", "time_scan"}


def _fit(effect: str, params: dict | None = None, nuisances: dict | None = None) -> FitResult:
    """A hypothesis at the given parameter values (no fit behind it)."""
    return FitResult(effect=effect, params=dict(params or {}), params_err={},
                     nuisances=dict(nuisances or {}), chi2=0.0, n_obs=1, n_par=0,
                     chi2_by_observable={}, n_by_observable={})


@pytest.fixture(scope="module")
def tone_prob():
    """The bundled campaign's problem, tone side only (no gate model)."""
    from dpdfit.analyses.diagnosis.observables import load_campaign
    from dpdfit.analyses.diagnosis.problem import Problem
    return Problem(load_campaign(BUNDLED_CAMPAIGN), with_gates=False)


BASE = _fit("baseline")
DETECTOR = _fit("detector_nonlinearity",
                {"detector_nonlinearity.k": 0.05, "detector_nonlinearity.q": 1.0})


def _stale(sa: tuple) -> FitResult:
    return _fit("stale_calibration", {**{f"stale_calibration.sa{i}": v for i, v in enumerate(sa)},
                                      "stale_calibration.kappa": 0.0,
                                      "stale_calibration.tau_d": 5.0})


def test_tone_side_difference_picks_a_tone_side_recording(tone_prob):
    """A detector nonlinearity changes the spectra only (no run-to-run signature, no
    phase curve): the proposal is spectra with a positive expected separation."""
    nm = propose_next_measurement(tone_prob, [BASE, DETECTOR])
    assert nm.what == "spectra"
    assert nm.expected_delta_bic > 0 and nm.per_hour > 0
    assert nm.settings["dpd"] == [0, 1]
    assert all(0.05 <= a <= 1.0 for a in nm.settings["amplitudes"])
    assert nm.separates == ["baseline", "detector_nonlinearity"]
    by_kind = {m["what"]: m for m in nm.menu}
    assert by_kind["amplitude_run"]["expected_delta_bic"] == 0.0
    assert by_kind["phase_run"]["expected_delta_bic"] == pytest.approx(0.0, abs=1e-9)


def test_more_amplitudes_separate_more(tone_prob):
    """Spectra at more amplitudes separate at least as much, and cost proportionally more."""
    nm = propose_next_measurement(tone_prob, [BASE, DETECTOR])
    spectra = [m for m in nm.menu if m["what"] == "spectra"]
    n = [len(m["settings"]["amplitudes"]) for m in spectra]
    delta = [m["expected_delta_bic"] for m in spectra]
    assert n == sorted(n) and delta == sorted(delta)
    for m in spectra:
        assert m["lab_seconds"] == pytest.approx(
            2 * len(m["settings"]["amplitudes"]) * LAB_TIMES.spectrum_trace_s)


def test_amplitude_run_separation_is_the_asimov_chi2(tone_prob):
    """A drifted AOM moves the next calibration run by its drift (in run-to-run sd):
    against a hypothesis without drift the expected delta BIC is sum(sa^2)."""
    assert tone_prob.runs_after is None and len(tone_prob.tone.drift_modes) >= 1
    sa = (3.0, -1.0, 0.5)[:len(tone_prob.tone.drift_modes)]
    nm = propose_next_measurement(tone_prob, [_stale(sa), DETECTOR])
    run = next(m for m in nm.menu if m["what"] == "amplitude_run")
    one = float(np.sum(np.square(sa)))                  # one run: the Asimov chi2
    k = int(np.ceil(decisive_target() / one))           # repeated until it decides
    assert run["expected_delta_bic"] == pytest.approx(k * one)
    assert run["settings"] == {"runs": k}
    # the rate of separation per lab hour does not change with the repeats
    assert run["per_hour"] == pytest.approx(one / (LAB_TIMES.amplitude_run_s / 3600))
    assert run["lab_seconds"] == pytest.approx(k * LAB_TIMES.amplitude_run_s)


def test_identical_hypotheses_separate_by_nothing(tone_prob):
    nm = propose_next_measurement(tone_prob, [DETECTOR, DETECTOR])
    assert isinstance(nm, NextMeasurement)
    assert nm.what in KINDS and nm.reason.startswith("no recording of the menu separates")
    assert nm.expected_delta_bic == 0.0 and nm.per_hour == 0.0
    assert nm.to_dict()["decisive"] is False
    assert all(m["expected_delta_bic"] == pytest.approx(0.0, abs=1e-12) for m in nm.menu)
    # nothing separates them: the shortest item is named, and the sentence says so
    assert nm.lab_seconds == min(m["lab_seconds"] for m in nm.menu)
    assert "constrain the size of detector_nonlinearity" in nm.sentence()


def test_without_gates_no_gate_recording_is_proposed(tone_prob):
    nm = propose_next_measurement(tone_prob, [BASE, DETECTOR, _stale((1.0,))])
    assert not GATE_KINDS & {m["what"] for m in nm.menu}
    assert {"amplitude_run", "phase_run", "spectra"} <= {m["what"] for m in nm.menu}
    # three hypotheses: the smallest separation of the first from the others counts
    assert nm.separates == ["baseline", "detector_nonlinearity", "stale_calibration"]


def test_more_hypotheses_take_the_smallest_separation(tone_prob):
    two = propose_next_measurement(tone_prob, [BASE, DETECTOR])
    three = propose_next_measurement(tone_prob, [BASE, DETECTOR, BASE])
    for a, b in zip(two.menu, three.menu):
        assert a["what"] == b["what"]
        assert b["expected_delta_bic"] == pytest.approx(0.0, abs=1e-9)


def test_to_dict_has_exactly_the_contract_keys(tone_prob):
    nm = propose_next_measurement(tone_prob, [BASE, DETECTOR])
    d = nm.to_dict()
    assert set(d) == CONTRACT_KEYS
    assert all(set(m) - {"reason"} == CONTRACT_KEYS - {"menu"} for m in d["menu"])
    assert all(m["what"] in KINDS for m in d["menu"])
    s = nm.sentence()
    assert s.startswith("Next: spectra at A = ") and s.endswith(".") and s.count(". ") == 0
    assert "separate baseline from detector_nonlinearity" in s


def test_lab_times_rank_the_menu(tone_prob):
    """A lab whose spectra take a month each is sent to the (decisive) calibration run."""
    hyps = [_stale((4.0,)), DETECTOR]
    assert propose_next_measurement(tone_prob, hyps).what == "spectra"
    slow = LabTimes(spectrum_trace_s=30 * 86400.0)
    nm = propose_next_measurement(tone_prob, hyps, lab=slow)
    # one run separates by 16, two by 32: the first that decides with 95 % probability
    assert decisive_target() == pytest.approx(27.14, abs=0.01)
    assert nm.what == "amplitude_run" and nm.expected_delta_bic == pytest.approx(32.0)
    assert nm.settings == {"runs": 2}


def test_nothing_buildable_gives_a_reason():
    prob = SimpleNamespace(tone=None, tone_noise=None, gate=None, ts=None, runs_after=None,
                           camp=SimpleNamespace(calibration_noise={}))
    nm = propose_next_measurement(prob, [BASE, DETECTOR])
    assert nm.what is None and isinstance(nm.reason, str) and nm.reason
    assert nm.to_dict() == {"what": None, "reason": nm.reason}
    assert nm.sentence().startswith("No next measurement proposed")


def test_fewer_than_two_hypotheses_gives_a_reason(tone_prob):
    nm = propose_next_measurement(tone_prob, [DETECTOR])
    assert nm.what is None and "two hypotheses" in nm.reason


# ----------------------------------------------------------------- gate side (stub)
class _StubGate:
    """Two settings; the contrast drops by ``dephasing.x`` at the second one."""

    keys = [(0.5, 0), (0.7, 1)]
    ts_keys: list = []
    sig_jit = 0.0
    gates = pd.DataFrame({"A": [0.5, 0.7], "dpd": [0, 1], "shots": [2500.0, 2500.0],
                          "n_scans": [4, 4]})

    def rate_error_db(self):
        return 0.0

    def predict(self, p):
        x = p.get("dephasing.x", 0.0)
        one = np.ones(2)
        out = {"F_pop": 0.99 * one, "imb": 0.0 * one, "C": np.array([0.98, 0.98 - x])}
        for q in ("F_pop", "imb", "C"):
            out["dlin_" + q] = 0.0 * one
            out["dquad_" + q] = 0.0 * one
        return out


def test_gate_side_difference_picks_the_parity_scan_where_it_differs():
    prob = SimpleNamespace(tone=None, tone_noise=None, gate=_StubGate(), ts=None,
                           runs_after=None, camp=SimpleNamespace(has_imbalance=True))
    a, b = _fit("spam_offset"), _fit("dephasing", {"dephasing.x": 0.02})
    nm = propose_next_measurement(prob, [a, b])
    assert nm.what == "parity"
    assert nm.settings["A"] == 0.7 and nm.settings["dpd"] == 1
    N = 625 * ERROR_MODEL.parity_phases                  # typical shots per scan x phases
    assert nm.settings["shots"] == N
    C = 0.98 - 0.01                                       # the pair's mean contrast
    one_scan = 0.02 ** 2 / (2 * (1 - 0.75 * C ** 2) / N)
    # repeated until decisive: ceil(10 / one scan) scans, each with its own noise
    k = int(np.ceil(decisive_target() / one_scan))
    assert nm.settings["scans"] == k and nm.lab_seconds == pytest.approx(k * N * 0.01)
    assert nm.expected_delta_bic == pytest.approx(k * one_scan)
    pops = [m for m in nm.menu if m["what"] == "populations"]
    assert len(pops) == 2 and all(m["expected_delta_bic"] == 0.0 for m in pops)
    assert nm.lab_seconds == pytest.approx(k * N * LAB_TIMES.shot_s)


@pytest.mark.slow
def test_bundled_campaign_with_gates_sends_extra_dephasing_to_a_gate_scan():
    """On the bundled campaign with its gates: an extra dephasing of 50 /s against the
    baseline fit is told apart by a gate recording, not by the tone side."""
    import dataclasses

    from dpdfit.analyses.diagnosis.fitting import fit_hypothesis
    from dpdfit.analyses.diagnosis.observables import load_campaign
    from dpdfit.analyses.diagnosis.problem import Problem
    prob = Problem(load_campaign(BUNDLED_CAMPAIGN))
    base = fit_hypothesis(prob, ())
    deph = dataclasses.replace(base, effect="dephasing", params={
        "dephasing.rate": 50.0, "dephasing.f_cm": 0.0, "dephasing.beta": 1.0,
        "dephasing.during": 1.0})
    nm = propose_next_measurement(prob, [base, deph])
    assert nm.what in GATE_KINDS and nm.expected_delta_bic > 0
    tone_side = [m for m in nm.menu if m["what"] in ("amplitude_run", "phase_run", "spectra")]
    assert tone_side and all(m["expected_delta_bic"] == pytest.approx(0.0, abs=1e-9)
                             for m in tone_side)
    assert nm.settings["A"] in set(prob.gate.gates["A"])
