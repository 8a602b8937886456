"""The gate side's evaluation shortcuts give exactly what the plain computation gives.

A prediction evaluates its three power errors along one leading axis, keeps the fixed
preparation branches' terms and the gate settings' values, builds the confusion matrix
without ``np.kron``, and the residuals keep the recordings' stacks: each is checked here
against the computation it replaces, bit for bit (the whitening's batched Cholesky
against one setting at a time, to the last digits).
"""

import numpy as np
import pytest

from dpdfit.analyses.diagnosis.effects import Prep
from dpdfit.analyses.diagnosis.model.gates.gate_model import POWER_STEP_DB, GateModel
from dpdfit.analyses.diagnosis.model.gates.gate_residuals import GateResiduals
from dpdfit.analyses.diagnosis.model.gates.observe import (PHASES, BranchMixer, branch_terms,
                                                           collapse, confusion_t, contrast,
                                                           decohere, observe)
from dpdfit.analyses.diagnosis.model.gates.whitening import (whiten_prediction,
                                                             whiten_settings, whiten_stacked)
from dpdfit.analyses.diagnosis.model.tones.tone_model import ToneModel
from dpdfit.analyses.diagnosis.observables.campaign import load_campaign
from tests.helpers.bundled_data import CAMPAIGN

EFFECTS = ("dephasing", "motional_heating", "spam_offset", "gate_rate_miscalibration")
NUIS = {"prep_split": 0.3, "e01": 6e-5, "e10": 4e-5, "eps_ts0": 0.02}


@pytest.fixture(scope="module")
def campaign():
    return load_campaign(CAMPAIGN)


@pytest.fixture(scope="module")
def gate_model(campaign):
    return GateModel(campaign, ToneModel(campaign), 0.05, effects=EFFECTS)


def test_the_confusion_matrix_is_krons():
    for e01, e10 in ((5e-5, 5e-5), (1e-3, 2e-4), (0.0, 0.0), (0.3, 0.01)):
        C = np.array([[1 - e01, e10], [e01, 1 - e10]])
        assert np.array_equal(confusion_t(Prep(0.0, 0.0, e01, e10)), np.kron(C, C).T)


def test_decoherence_along_leading_axes_is_that_of_each_stack():
    rng = np.random.default_rng(1)
    par = rng.dirichlet(np.ones(4), (3, 6, PHASES.size))
    k1, k2 = rng.uniform(0.5, 1.0, 6), rng.uniform(0.5, 1.0, 6)
    got = decohere(par, k1, k2)
    for i in range(3):
        assert np.array_equal(got[i], decohere(par[i], k1, k2))


def test_kept_branch_terms_mix_as_fresh_ones():
    rng = np.random.default_rng(2)
    p2, p01 = rng.dirichlet(np.ones(4), (3, 5)), rng.dirichlet(np.ones(4), (3, 5))
    p1, p1_1 = rng.dirichlet(np.ones(2), (3, 5)), rng.dirichlet(np.ones(2), (3, 5))
    terms = branch_terms(p1, p01, p1_1)
    for q, f in ((0.002, 0.001), (0.003, 0.0), (0.0, 0.002), (0.0, 0.0)):
        prep = Prep(q, f, 6e-5, 4e-5)
        assert np.array_equal(BranchMixer(prep, p1, p01, p1_1, terms)(p2),
                              BranchMixer(prep, p1, p01, p1_1)(p2))


def _one_at_a_time(gm, p):
    """The gate settings' values of ``gm.predict(p)`` with one evaluation per power error,
    nothing kept (the computation the prediction's shortcuts replace)."""
    from dpdfit.analyses.diagnosis.model.gates.effect_terms import (active_effects,
                                                                    effect_terms, preparation)
    gm._stk = gm._tab = None
    tab = gm._tables()
    active = active_effects(gm.effects, p)
    prep = preparation(gm, p, active)
    coefs, eps, coh, terms = effect_terms(gm, active, tab)["gate"]
    base, d, lin, quad = tab["gate"]
    h = POWER_STEP_DB / 3
    vals = []
    for e in (eps, eps + h, eps - h):
        pop, par = observe(base, d, lin, quad, coefs, e, tab["var"][0], prep, True, coh, terms)
        F, imb = collapse(pop)
        vals.append({"F_pop": F, "imb": imb, "C": contrast(par)})
    out = {}
    for q in ("F_pop", "imb", "C"):
        out[q] = vals[0][q]
        out["dlin_" + q] = (vals[1][q] - vals[2][q]) / (2 * h)
        out["dquad_" + q] = (vals[1][q] + vals[2][q] - 2 * vals[0][q]) / (2 * h * h)
    return out


def test_a_prediction_is_its_power_errors_one_at_a_time(gate_model):
    walk = [{}, NUIS, {**NUIS, "dephasing.rate": 5.0},
            {**NUIS, "motional_heating.ndot": 0.3, "spam_offset.p_extra": 1e-3},
            {**NUIS, "gate_rate_miscalibration.eps": 0.05}]
    for p in walk:
        gate_model._stk = gate_model._tab = None
        got = gate_model.predict(p)
        want = _one_at_a_time(gate_model, p)
        assert all(np.array_equal(got[k], want[k]) for k in want), p


def test_kept_gate_values_follow_every_parameter(gate_model):
    """A fit moves one parameter at a time: a time scan's rate error, a detection error,
    the preparation split, an effect; each prediction equals one from nothing."""
    walk = [NUIS, {**NUIS, "eps_ts0": 0.05}, {**NUIS, "e10": 9e-5}, {**NUIS, "prep_split": 0.7},
            {**NUIS, "dephasing.rate": 5.0}, {**NUIS, "dephasing.rate": 5.0, "eps_ts0": -0.1},
            NUIS]
    gate_model._stk = gate_model._tab = None
    for p in walk:
        got = gate_model.predict(p)
        gate_model._stk = gate_model._tab = None
        want = gate_model.predict(p)
        assert set(got) == set(want)
        assert all(np.array_equal(got[k], want[k]) for k in want), p
    # a new rate scatter changes the variances of the values kept
    before = gate_model.predict(NUIS)["var_F_pop"]
    gate_model.set_rate_scatter(0.05)
    after = gate_model.predict(NUIS)["var_F_pop"]
    gate_model._stk = gate_model._tab = None
    assert np.array_equal(after, gate_model.predict(NUIS)["var_F_pop"])
    assert not np.array_equal(before, after)
    with pytest.raises(ValueError):
        after[0] = 0.0                                   # kept: read-only


def test_gate_residuals_are_those_of_the_recordings(campaign, gate_model):
    res = GateResiduals(gate_model.gates, campaign.time_scans)
    pr = gate_model.predict(NUIS)
    qs = res.observables
    assert np.array_equal(whiten_stacked(res._measured, res._shot, pr, qs),
                          whiten_prediction(res.measured, res.shot, pr, qs))
    blocks = {lab["observable"]: z for lab, z in res.gate_blocks(gate_model, NUIS, True)
              if lab["kind"] == "time_scan"}
    ts = res.ts
    N = ts["shots"].to_numpy(dtype=float)
    for q, col in (("P00_t", "n00"), ("P11_t", "n11")):
        pm = np.clip(pr[q], 0.5 / N, 1 - 0.5 / N)
        want = (ts[col].to_numpy() / N - pr[q]) / np.sqrt(pm * (1 - pm) / N)
        assert np.array_equal(blocks[q], want)


def test_whitening_is_each_settings_cholesky():
    rng = np.random.default_rng(6)
    n = 7
    r, g, h = rng.normal(size=(n, 3)), rng.normal(size=(n, 3)) * 0.01, rng.normal(size=(n, 3))
    shot = rng.uniform(0.01, 0.02, (n, 3))
    v_lin, v_quad = rng.uniform(0.01, 0.1, n), rng.uniform(1e-4, 1e-3, n)
    r[2, 1] = np.nan                                    # a setting without one observable
    for rows in (slice(None), [0, 1, 3, 4, 5, 6]):       # with and without it
        z, ld = whiten_settings(r[rows], shot[rows], g[rows], h[rows], v_lin[rows],
                                v_quad[rows], logdet=True)
        assert np.array_equal(z, whiten_settings(r[rows], shot[rows], g[rows], h[rows],
                                                 v_lin[rows], v_quad[rows]), equal_nan=True)
        want_ld = 0.0
        for i, k in enumerate(np.arange(n)[rows]):
            cov = (v_lin[k] * np.outer(g[k], g[k]) + v_quad[k] * np.outer(h[k], h[k])
                   + np.diag(shot[k] ** 2))
            if np.isfinite(r[k]).all():
                L = np.linalg.cholesky(cov)
                np.testing.assert_allclose(z[i], np.linalg.solve(L, r[k]), rtol=1e-13)
                want_ld += 2 * np.log(np.diag(L)).sum()
            else:
                ok = np.isfinite(r[k])
                np.testing.assert_allclose(z[i][ok], r[k][ok] / np.sqrt(np.diag(cov))[ok],
                                           rtol=1e-13)
                want_ld += np.log(np.diag(cov))[ok].sum()
        assert ld == pytest.approx(want_ld, rel=1e-13)
