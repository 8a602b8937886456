"""The diagnosis's forward models keep what a fit evaluates again; what they keep is exactly
what they would compute again.

Every cache of the tone engines (quadrature, interpolation weights, harmonic tables, the
drive power's spectra, the filtered drive, the features of recent parameter sets) and of
the gate side (every engine branch's outcome, the fixed preparation branches of a
prediction) is checked against a computation that starts from nothing: bit for bit,
whatever was evaluated before.
"""

import numpy as np
import pytest

from dpdfit.analyses.diagnosis.model.gates import engine_runs
from dpdfit.analyses.diagnosis.effects import Prep
from dpdfit.analyses.diagnosis.model.gates.observe import BranchMixer, confusion_t
from dpdfit.analyses.diagnosis.model.tones.interpolation import (cubic_apply, cubic_weights,
                                                                 uniform_at, uniform_interp,
                                                                 uniform_place)
from dpdfit.analyses.diagnosis.observables.campaign import load_campaign
from dpdfit.analyses.diagnosis.model.tones.tone_model import ToneModel
from dpdfit.models import gate_sim
from dpdfit.models.gate_sim.drive import Drive
from tests.helpers.bundled_data import CAMPAIGN

SLOW = {"aom_memory.gain_a": 0.01, "aom_memory.gain_p": 0.05, "aom_memory.tau1": 1.0,
        "aom_memory.tau2": 3.0, "aom_memory.w": 0.2, "aom_memory.delay": 30.0,
        "aom_memory.tau": 0.0, "aom_memory.f_off": 0.0}
FAST = {"aom_memory.tau": 60.0, "aom_memory.f_off": 2.0, "aom_memory.gain_a": 0.0,
        "aom_memory.gain_p": 0.0}
STALE = {"stale_calibration.st0": 0.4, "stale_calibration.sa0": 0.0,
         "stale_calibration.kappa": 0.0, "stale_calibration.tau_d": 5.0}
#: a fit's walk: a kernel moved at fixed tables, the gain, the modes one curve at a time
#: (amplitude, phase, both), a stale table asked again, back to a point seen
WALK = [{}, SLOW, {**SLOW, "aom_memory.tau1": 1.5}, {**SLOW, "aom_memory.delay": 50.0},
        {**SLOW, "aom_memory.gain_a": 0.02}, {**SLOW, "cal_amp0": 0.4}, SLOW,
        {**SLOW, "cal_phase0": 0.3}, {**SLOW, "cal_amp0": 0.4, "cal_phase0": 0.3},
        {**SLOW, "aom_memory.gain_a": 0.02, "aom_memory.tau1": 1.5}, SLOW,
        FAST, {**FAST, "cal_amp0": 0.3}, {**FAST, "aom_memory.tau": 70.0},
        {**FAST, "cal_phase0": -0.2}, FAST,
        {"detector_nonlinearity.k": 0.02}, {"cal_amp0": -0.5, "cal_phase0": 0.2},
        {"detector_nonlinearity.k": 0.02, "cal_amp0": -0.5},
        STALE, {**STALE, "cal_amp0": 0.2}, {**STALE, "stale_calibration.st0": 0.5}, STALE,
        {**STALE, **SLOW}, {**STALE, **SLOW, "aom_memory.gain_p": 0.07},
        {"higher_order_im.k5": 0.01}, {"am_pm_omitted.dphi": 0.05}, {}]


@pytest.fixture(scope="module")
def campaign():
    return load_campaign(CAMPAIGN)


def test_tone_model_caches_give_what_a_fresh_model_computes(campaign):
    tone = ToneModel(campaign)
    for sign in (1, -1):
        kept = tone.with_phase_sign(sign)
        for p in WALK:
            fresh = ToneModel(campaign).with_phase_sign(sign)
            assert np.array_equal(kept.P_dB(p), fresh.P_dB(p)), p
            got, want = kept.features(p), fresh.features(p)
            assert all(np.array_equal(got[k], want[k]) for k in want), p
            at = kept.tone_powers_at([0.3, 0.7], p)
            assert np.array_equal(at, fresh.tone_powers_at([0.3, 0.7], p)), p
            g = kept.gate_tones(p, 0.5, 1)
            assert all(np.array_equal(a, b) for a, b in zip(g, fresh.gate_tones(p, 0.5, 1)))


def test_tone_residual_blocks_kept_are_those_computed_afresh(campaign):
    """The tone residuals keep the blocks of the last parameter set (read-only): asked
    again, and after other sets, they are those of a fresh computation."""
    from dpdfit.analyses.diagnosis.model.tones.tone_residuals import ToneResiduals
    tone = ToneModel(campaign)

    def residuals():
        return ToneResiduals(campaign.P_dB, campaign.A_tones, campaign.sd_dB, 0.05,
                             np.ones(len(campaign.A_tones))[:, None, None])

    kept = residuals()
    for p in (SLOW, SLOW, {**SLOW, "cal_amp0": 0.4}, {}, {}, SLOW):
        got, want = kept.feature_blocks(tone, p), residuals().feature_blocks(ToneModel(campaign), p)
        assert [lab for lab, _ in got] == [lab for lab, _ in want]
        assert all(np.array_equal(a, b, equal_nan=True) for (_, a), (_, b) in zip(got, want)), p
        with pytest.raises(ValueError):
            got[0][1][0] = 0.0


def test_a_slow_memory_kernel_moves_the_tones_at_kept_tables(campaign):
    """The harmonic tables are kept across a kernel's change: the tones must still move."""
    tone = ToneModel(campaign)
    a = tone.P_dB(SLOW)
    for k, v in (("aom_memory.tau1", 2.0), ("aom_memory.w", 0.5), ("aom_memory.delay", 80.0),
                 ("aom_memory.gain_p", 0.1)):
        b = tone.P_dB({**SLOW, k: v})
        assert not np.array_equal(a, b), k
    # kept values are shared, so nobody may write into them
    with pytest.raises(ValueError):
        tone.features(SLOW)["gate_power"][0] = 0.0


def test_the_caches_are_not_pickled(campaign):
    import pickle
    tone = ToneModel(campaign)
    tone.P_dB(FAST)
    copy = pickle.loads(pickle.dumps(tone))
    assert not [k for k in vars(copy) if k.endswith("_cache")]
    assert np.array_equal(copy.P_dB(FAST), tone.P_dB(FAST))


def test_interpolation_helpers_match_the_gathers():
    rng = np.random.default_rng(3)
    x = rng.uniform(-0.1, 1.1, (7, 33))
    tables = rng.normal(size=(3, 65)) + 1j * rng.normal(size=(3, 65))
    K = tables.shape[-1] - 1
    s = np.clip(x, 0.0, 1.0) * K
    i = np.clip(np.floor(s).astype(np.intp) - 1, 0, K - 3)
    f = s - i
    ls = (-(f - 1) * (f - 2) * (f - 3) / 6, f * (f - 2) * (f - 3) / 2,
          -f * (f - 1) * (f - 3) / 2, f * (f - 1) * (f - 2) / 6)
    direct = sum(l * tables[..., i + j] for j, l in enumerate(ls))
    assert np.array_equal(cubic_apply(tables, cubic_weights(x, K)), direct)
    assert np.array_equal(cubic_apply(tables[1], cubic_weights(x, K)), direct[1])
    t = tables[0]
    assert np.array_equal(uniform_at(uniform_place(x, K), t, t[1:] - t[:-1]),
                          uniform_interp(x, t))


def test_gate_branch_mixing_matches_the_engine_functions():
    rng = np.random.default_rng(4)
    p2, p01 = rng.dirichlet(np.ones(4), (3, 5)), rng.dirichlet(np.ones(4), (3, 5))
    p1, p1_1 = rng.dirichlet(np.ones(2), (3, 5)), rng.dirichlet(np.ones(2), (3, 5))
    for q, f in ((0.002, 0.001), (0.003, 0.0), (0.0, 0.002), (0.0, 0.0)):
        prep = Prep(q, f, 6e-5, 4e-5)
        want = gate_sim.confusion(gate_sim.mix_branches(p2, p1, q, f, p01, None, p1_1),
                                  (prep.e01, prep.e10))
        assert np.array_equal(BranchMixer(prep, p1, p01, p1_1)(p2) @ confusion_t(prep), want)


def test_the_master_equation_couplings_are_those_of_K():
    rng = np.random.default_rng(5)
    for ions in (1, 2):
        b, c = (rng.normal(size=4) + 1j * rng.normal(size=4) for _ in range(2))
        drive = Drive(b, c, np.array([-1, 1, 2, 3]), 2e4, 3e3, ions)
        for tau in (0.0, 0.37, 1.0):
            mK, mKd = drive.minus_iK(tau)
            K = drive.K(tau)
            assert np.array_equal(mK, -1j * K)
            assert np.array_equal(mKd, -(-1j * K).conj().T)


B_T = np.array([0.02, 0.5, -0.5])
N_T = np.array([0, 1, 2])
XI0 = 3.4e3
EO = XI0 / gate_sim.calibrate_xi0(B_T, B_T, N_T, 1.0)
KW = dict(nbar=0.05, T2=0.05, ndot=5.0, scan_times=np.array([0.5 / XI0]), rtol=1e-4,
          atol=1e-6, fock_tol=1e-6)


def test_engine_runs_are_kept_branch_by_branch(monkeypatch):
    engine_runs.clear_run_cache()
    direct = gate_sim.setting_branches(B_T, B_T, N_T, EO, XI0, **KW)
    ran = []
    real = gate_sim.setting_branches

    def counting(*a, **kw):
        ran.append(kw.get("branches"))
        return real(*a, **kw)

    monkeypatch.setattr(engine_runs.gate_sim, "setting_branches", counting)
    monkeypatch.setenv("DPDFIT_WORKERS", "1")
    args = (B_T, B_T, N_T, EO, XI0)
    two = engine_runs.run_settings([(args, {**KW, "spectator": False, "flip": False})],
                                   [(0.5, 0)])[0]
    assert ran == [("2",)]
    full = engine_runs.run_settings([(args, KW)], [(0.5, 0)])[0]
    assert sorted(ran[1:]) == [("1",), ("1_1",), ("2_01",)]     # the two-ion branch kept
    again = engine_runs.run_settings([(args, KW), (args, KW)], [(0.5, 0), (0.5, 0)])
    assert len(ran) == 4                                        # nothing integrated again
    assert set(full) == set(direct) and set(two) == {"p2", "par2", "phases", "times"}
    for run in (full, *again):
        assert all(np.array_equal(run[k], direct[k]) for k in direct)
    with pytest.raises(ValueError):
        full["p2"][0, 0] = 1.0                                   # shared: read-only
    engine_runs.clear_run_cache()


def test_gate_predictions_with_kept_parts_match_a_prediction_from_nothing(campaign):
    from dpdfit.analyses.diagnosis.model.gates.gate_model import GateModel
    effects = ("dephasing", "motional_heating", "spam_offset", "gate_rate_miscalibration")
    gm = GateModel(campaign, ToneModel(campaign), 0.05, effects=effects)
    nuis = {"prep_split": 0.3, "e01": 6e-5, "e10": 4e-5, "eps_ts0": 0.02}
    walk = [{}, nuis, {**nuis, "e01": 8e-5}, {**nuis, "prep_split": 0.6},
            {**nuis, "dephasing.rate": 5.0}, {**nuis, "dephasing.rate": 5.0, "e10": 1e-5},
            {**nuis, "motional_heating.ndot": 0.3, "spam_offset.p_extra": 1e-3},
            {**nuis, "gate_rate_miscalibration.eps": 0.05}, nuis, {}]
    for p in walk:
        got = gm.predict(p)
        gm._stk = gm._tab = None                      # forget every part kept
        want = gm.predict(p)
        assert set(got) == set(want)
        assert all(np.array_equal(got[k], want[k]) for k in want), p
