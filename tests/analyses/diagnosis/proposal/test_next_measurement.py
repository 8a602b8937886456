"""The next measurement a diagnosis proposes when it cannot decide between hypotheses.

Hypotheses are :class:`FitResult` objects made by hand (parameter sets at chosen
values), so that the expected separations are known; the tone side runs on the
bundled campaign without its gates (about a second), the gate side on a stub gate
model.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from dpdfit.analyses.diagnosis.fitting.fit_result import FitResult
from dpdfit.analyses.diagnosis.proposal.next_measurement import (KINDS, NextMeasurement,
                                                                 decisive_target,
                                                                 propose_next_measurement)
from dpdfit.core.defaults import ERROR_MODEL, LAB_TIMES, LabTimes
from tests.helpers.paths import ROOT

BUNDLED_CAMPAIGN = ROOT / "datasets" / "synthetic_campaign"
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
    from dpdfit.analyses.diagnosis.observables.campaign import load_campaign
    from dpdfit.analyses.diagnosis.model.residuals import Problem
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
    # a further phase run is fitted as data, but neither hypothesis moves the AOM's phase
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


def test_spectra_carry_the_tone_repeatability_they_were_predicted_with(tone_prob):
    """Each spectra item states the tone repeatability its traces are predicted with (the
    campaign's learnt one), and the schedule writes it on every trace."""
    from dpdfit.analyses.diagnosis.proposal.schedule import proposal_schedule
    nm = propose_next_measurement(tone_prob, [BASE, DETECTOR])
    sd = tone_prob.tone_noise.s_tone_db
    assert sd > 0
    for m in nm.menu:
        if m["what"] == "spectra":
            assert m["settings"]["tone_sd_db"] == sd
    df = proposal_schedule(nm, BUNDLED_CAMPAIGN)
    assert (df["tone_sd_db"] == sd).all()
    assert len(df) == 2 * len(nm.settings["amplitudes"])
    assert df["lab_s"].sum() == pytest.approx(nm.lab_seconds, rel=1e-12)
    np.testing.assert_allclose(df["lab_s"], LAB_TIMES.spectrum_trace_s, rtol=1e-12)


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
    assert {"amplitude_run", "spectra"} <= {m["what"] for m in nm.menu}
    # offered (fitted as data), separating nothing: no hypothesis moves the AOM's phase
    assert all(m["expected_delta_bic"] == pytest.approx(0.0, abs=1e-9)
               for m in nm.menu if m["what"] == "phase_run")
    # three hypotheses: the smallest separation of the first from the others counts
    assert nm.separates == ["baseline", "detector_nonlinearity", "stale_calibration"]


def test_more_hypotheses_take_the_smallest_separation(tone_prob):
    two = propose_next_measurement(tone_prob, [BASE, DETECTOR])
    three = propose_next_measurement(tone_prob, [BASE, DETECTOR, BASE])
    for a, b in zip(two.menu, three.menu):
        assert a["what"] == b["what"]
        assert b["expected_delta_bic"] == pytest.approx(0.0, abs=1e-9)


#: keys added to the contract: the separation predicted (held, linearised, refitted),
#: the hypotheses' forms and the pair that set it; per menu item its held separation
#: (and the linearised one where a refit confirmed it)
ADDED_KEYS = {"predicted_separation", "hypotheses", "binding", "replicates"}
ADDED_ITEM_KEYS = {"separation_fixed", "separation_linearised"}


def test_to_dict_has_the_contract_keys_and_only_the_added_ones(tone_prob):
    nm = propose_next_measurement(tone_prob, [BASE, DETECTOR])
    d = nm.to_dict()
    assert set(d) == CONTRACT_KEYS | ADDED_KEYS
    assert set(d["predicted_separation"]) == {"fixed", "linearised", "refit"}
    assert all(CONTRACT_KEYS - {"menu"} <= set(m) <= CONTRACT_KEYS | ADDED_ITEM_KEYS
               | {"reason"} for m in d["menu"])
    assert all(m["what"] in KINDS for m in d["menu"])
    # each of the binding pair with the separation expected if it is the true one: the
    # binding direction's is the proposal's (the smaller), the reverse one at least 0
    b = d["binding"]
    assert set(b) == {"truth", "rival"}
    assert b["truth"]["expected_delta_bic"] == pytest.approx(nm.expected_delta_bic)
    assert b["rival"]["expected_delta_bic"] >= b["truth"]["expected_delta_bic"] - 1e-9
    assert {"effects", "forms"} <= set(b["truth"]) and {"effects", "forms"} <= set(b["rival"])
    # fits made by hand have no covariance: no replicates, the expected figure decides
    assert d["replicates"] == {"basis": "expected_delta_bic",
                               "why": "a hypothesis has no covariance to draw its "
                                      "parameters from"}
    s = nm.sentence()
    assert s.startswith("Next: spectra at A = ") and s.endswith(".") and s.count(". ") == 0
    assert "separate baseline from detector_nonlinearity" in s


def test_lab_times_rank_the_menu(tone_prob):
    """A lab whose spectra take a month each is sent to the (decisive) calibration run."""
    hyps = [_stale((4.0,)), DETECTOR]
    assert propose_next_measurement(tone_prob, hyps).what == "spectra"
    # (a lab with an attenuator at hand is sent to the detector linearity check, minutes:
    # tests/analyses/diagnosis/proposal/test_detector_linearity_menu.py; this one has none)
    slow = LabTimes(spectrum_trace_s=30 * 86400.0, attenuator_swap_s=30 * 86400.0)
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

    def rate_error_db(self, key=None):
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


class _StubGateSharedRateError(_StubGate):
    """The same two settings; each setting's rate calibration is off by 0.05 dB (one
    draw shared by every scan of the setting), which moves the contrast."""

    def rate_error_db(self, key=None):
        return 0.05

    def predict(self, p):
        out = super().predict(p)
        out["dlin_C"] = np.array([0.2, 0.2])          # dC per dB of power error
        return out


def test_scans_of_a_setting_pool_and_their_shared_rate_error_does_not_average():
    """k more scans of a recorded setting add ``Q_k = S(n+k)^-1 - S(n)^-1``: the
    setting's rate-calibration error is common to all its scans, so the separation
    saturates at what that error allows, and the proposal says it cannot decide rather
    than asking for a working day of scans as if they were independent."""
    prob = SimpleNamespace(tone=None, tone_noise=None, gate=_StubGateSharedRateError(),
                           ts=None, runs_after=None, camp=SimpleNamespace(has_imbalance=True))
    a, b = _fit("spam_offset"), _fit("dephasing", {"dephasing.x": 0.02})
    nm = propose_next_measurement(prob, [a, b])
    par = next(m for m in nm.menu if m["what"] == "parity" and m["settings"]["A"] == 0.7)
    N = 625 * ERROR_MODEL.parity_phases
    C, n = 0.97, 4
    shot1 = 2 * (1 - 0.75 * C ** 2) / N                  # one scan's contrast variance
    vx = (0.2 * 0.05) ** 2 + 2 * 0.0                      # the shared part (dquad = 0)

    def info(k):                                          # delta^2 (S(n+k)^-1 - S(n)^-1)
        return 0.02 ** 2 * (1 / (shot1 / (n + k) + vx) - 1 / (shot1 / n + vx))
    # nothing a working day of scans gives reaches the saturated information
    assert par["expected_delta_bic"] <= 0.02 ** 2 / vx - 0.02 ** 2 / (shot1 / n + vx) + 1e-9
    k = par["settings"]["scans"]
    assert par["expected_delta_bic"] == pytest.approx(info(k), rel=1e-9)
    # short of deciding, it is repeated until it has 95 % of a working day's worth: the
    # fewest scans that do, not the day's
    k_day = int(LAB_TIMES.max_seconds // (N * LAB_TIMES.shot_s))
    assert info(k) >= 0.95 * info(k_day) > info(k - 1) and k < k_day
    assert nm.what is None or nm.expected_delta_bic < decisive_target()
    assert nm.reason and "short of" in nm.reason


def test_a_time_scan_is_proposed_with_one_scans_shots_when_points_are_pooled():
    """A time-scan point recorded by 40 scans of 625 shots is one pooled row of 25,000
    shots: a further scan has 625 per point, not 25,000."""
    from dpdfit.analyses.diagnosis.proposal.menu import BUILDERS
    ts = pd.DataFrame({"A": 0.6, "dpd": 1, "t_s": [1e-4, 2e-4], "n00": 12000, "n11": 12000,
                       "shots": 25000, "n_repeats": 40})
    gate = SimpleNamespace(ts_keys=[(0.6, 1)])
    prob = SimpleNamespace(gate=gate, ts=ts)
    hyp = SimpleNamespace(raw=lambda source: {"P00_t": np.array([0.5, 0.4]),
                                              "P11_t": np.array([0.5, 0.4])})
    build = next(b for b in BUILDERS if b.__name__ == "_time_scans")
    (item,) = build(prob, [hyp, hyp], LAB_TIMES)
    assert item.settings == {"A": 0.6, "dpd": 1, "shots": 625, "points": 2}
    assert item.seconds == pytest.approx(2 * 625 * LAB_TIMES.shot_s)


@pytest.mark.slow
def test_bundled_campaign_with_gates_sends_extra_dephasing_to_a_ramsey_scan():
    """On the bundled campaign with its gates: an extra dephasing of 50 /s against the
    baseline fit is told apart by a Ramsey scan (minutes of free precession, decisive), the
    gate recordings separate it too, the tone side not at all."""
    import dataclasses

    from dpdfit.analyses.diagnosis.fitting.hypothesis_fit import fit_hypothesis
    from dpdfit.analyses.diagnosis.observables.campaign import load_campaign
    from dpdfit.analyses.diagnosis.model.residuals import Problem
    prob = Problem(load_campaign(BUNDLED_CAMPAIGN))
    base = fit_hypothesis(prob, ())
    deph = dataclasses.replace(base, effect="dephasing", params={
        "dephasing.rate": 50.0, "dephasing.f_cm": 0.0, "dephasing.beta": 1.0,
        "dephasing.during": 1.0})
    nm = propose_next_measurement(prob, [base, deph])
    assert nm.what == "ramsey" and nm.decisive and nm.lab_seconds < 600
    gates = [m for m in nm.menu if m["what"] in GATE_KINDS]
    assert gates and all(m["expected_delta_bic"] > 0 for m in gates)
    tone_side = [m for m in nm.menu if m["what"] in ("amplitude_run", "phase_run", "spectra")]
    assert tone_side and all(m["expected_delta_bic"] == pytest.approx(0.0, abs=1e-9)
                             for m in tone_side)


# ----------------------------------------------------------------- profiled separation
class _LinearHypothesis:
    """A hypothesis whose prediction of a new recording is linear in its parameters:
    ``m(theta) = m0 + X theta``, with covariance ``C`` from the recordings so far."""

    def __init__(self, m0, X, C, label):
        self.m0, self.X = np.asarray(m0, float), np.asarray(X, float)
        self.C = None if C is None else np.asarray(C, float)
        self.keys = [f"t{i}" for i in range(self.X.shape[1])]
        self.p = {k: 0.0 for k in self.keys}
        self.label = label

    def absorbing(self, source):
        return [(k, 1e-3) for k in self.keys]

    def covariance(self, keys):
        return self.C

    def predict(self, p=None):
        p = self.p if p is None else p
        return self.m0 + self.X @ np.array([p[k] for k in self.keys])


class _Item:
    source = "gates"

    def __init__(self, sd):
        self.sd = np.asarray(sd, float)

    def vector(self, h, p=None):
        return h.predict(p)


def test_profiled_separation_is_the_rival_refitted_to_the_truths_recording():
    """For a rival linear in its parameters the Woodbury form is exact: k repeats of the
    recording, the rival refitted to them with its information from the recordings so
    far, leave min_theta k |W (m_a - m_b(theta))|^2 + theta^T C^-1 theta; the exact
    refit finds the same, and holding the parameters gives the larger k d.d."""
    from dpdfit.analyses.diagnosis.proposal.expected_separation import (Direction as _Direction)
    rng = np.random.default_rng(11)
    n, q = 12, 3
    sd = rng.uniform(0.5, 2.0, n)
    X = rng.normal(size=(n, q))
    C = np.diag(rng.uniform(0.1, 1.0, q))
    a = _LinearHypothesis(rng.normal(size=n), np.zeros((n, 0)), np.zeros((0, 0)), "a")
    b = _LinearHypothesis(rng.normal(size=n), X, C, "b")
    W = 1.0 / sd
    d = _Direction(_Item(sd), a, b, W, profile=True)
    for k in (1, 3, 10):
        # brute force: the stacked least-squares problem
        A = np.vstack([np.sqrt(k) * (W[:, None] * X), np.linalg.cholesky(np.linalg.inv(C)).T])
        y = np.concatenate([np.sqrt(k) * W * (a.m0 - b.m0), np.zeros(q)])
        theta, *_ = np.linalg.lstsq(A, y, rcond=None)
        want = float(np.sum((y - A @ theta) ** 2))
        assert d.linearised(k)[0] == pytest.approx(want, rel=1e-9)
        assert d.refit(k) == pytest.approx(want, rel=1e-6)
        assert k * d.dd > want
    # without a covariance nothing is refitted: the held separation
    held = _Direction(_Item(sd), a, _LinearHypothesis(b.m0, X, None, "b"), W, profile=True)
    assert held.linearised(2)[0] == pytest.approx(2 * d.dd)


def test_the_expected_separation_is_what_a_refit_to_recorded_data_achieves():
    """Recordings drawn under the truth (noise included), the rival refitted to them and
    to its prior information: the achieved chi2 difference averages the predicted
    separation less the noise the rival's parameters absorb (their number, here 3)."""
    from dpdfit.analyses.diagnosis.proposal.expected_separation import (Direction as _Direction)
    rng = np.random.default_rng(12)
    n, q, k = 40, 3, 2
    sd = np.full(n, 1.0)
    X = rng.normal(size=(n, q))
    C = np.eye(q) * 0.5
    a = _LinearHypothesis(np.zeros(n), np.zeros((n, 0)), np.zeros((0, 0)), "a")
    b = _LinearHypothesis(0.6 * np.sin(np.arange(n)), X, C, "b")
    pred = _Direction(_Item(sd), a, b, 1.0 / sd, profile=True).linearised(k)[0]
    Ci = np.linalg.inv(C)
    L = np.linalg.cholesky(Ci).T
    got = []
    for _ in range(4000):
        y = a.m0[None, :] + rng.normal(size=(k, n))
        A = np.vstack([X] * k + [L])
        r = np.concatenate([(y - b.m0).ravel(), np.zeros(q)])
        theta, *_ = np.linalg.lstsq(A, r, rcond=None)
        chi_b = float(np.sum((r - A @ theta) ** 2))
        chi_a = float(np.sum((y - a.m0) ** 2))
        got.append(chi_b - chi_a)
    # E[achieved] = pred - tr(absorbed part of the noise) ~ pred - q (prior weak here)
    assert np.mean(got) == pytest.approx(pred - q, abs=0.6)


def test_repeated_spectra_are_described_once_per_amplitude_with_their_count():
    from dpdfit.analyses.diagnosis.proposal.next_measurement import (describe_recording as _describe)
    even = _describe("spectra", {"amplitudes": [0.8, 0.8, 0.85, 0.85], "dpd": [0, 1]})
    assert even == "spectra at A = 0.8, 0.85 (2 traces each) with and without DPD"
    uneven = _describe("spectra", {"amplitudes": [0.8, 0.8, 0.8, 0.85], "dpd": [0, 1]})
    assert uneven == "spectra at A = 0.8 x3, 0.85 with and without DPD"
    once = _describe("spectra", {"amplitudes": [0.95, 0.85], "dpd": [0, 1]})
    assert once == "spectra at A = 0.85, 0.95 with and without DPD"
