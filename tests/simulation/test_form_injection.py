"""Every form of every concealed effect can be injected by the simulator, through the
effect's own hooks, in the terms of the diagnosis's model of that form.

Fast checks hook by hook (the simulator's injection against the model's hook for the
same parameters), the calibration signatures of the stale table's forms on a reduced
campaign (calibration runs only), and, marked slow, the simulator's gate observables
and tone powers against the diagnosis's forward models on a tiny campaign."""

import dataclasses
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from dpdfit.analyses.diagnosis.effects import Prep
from dpdfit.fits.calibration import fit_amplitude
from dpdfit.models.gate_sim.dephasing import accumulated_dephasing
from dpdfit.simulation.campaign import simulate_campaign
from dpdfit.simulation.campaign.calibration_runs import table_index
from dpdfit.simulation.harness import concealed_effects, harness_config
from dpdfit.simulation.injections import get

SEED = 4242
GM = SimpleNamespace(t_ref=2.1e-4, A_ref=0.6)          # a gate model's references
KW = dict(nbar=0.1, T2=0.05, T2_corr=np.inf, ndot=5.0, p_prep=0.003, p_flip=0.0,
          p_det=5e-5, power_error_db=0.0)


def _model_values(e, v):
    """The model's values (its own parameters) of injected values ``v``."""
    names = {p.name for p in e.parameters()}
    return {k: x for k, x in e.injected(v).items() if k in names}


def _refs(e, v):
    return {**e.injected(v), **{k: getattr(GM, k) for k in e.inject_refs}}


@pytest.mark.parametrize("name", concealed_effects())
def test_every_form_has_harness_strengths_and_a_draw_takes_that_form(name):
    e = get(name)
    table = e.harness_table()
    assert list(table) == [f.name for f in e.forms_for()]
    rng = np.random.default_rng(1)
    for form, ranges in table.items():
        for _ in range(5):
            v = e.draw(rng, form)
            for p, (lo, hi, signed) in ranges.items():
                assert lo <= (abs(v[p]) if signed else v[p]) <= hi, (form, p, v[p])
            for p, x in e.form_values(form).items():
                assert v[p] == x
            assert set(e.injected(v)) <= set(e.injection_params())


def test_the_catalog_draw_is_the_catalog_harness_as_before():
    for name in concealed_effects():
        e = get(name)
        a, b = np.random.default_rng(9), np.random.default_rng(9)
        v = e.draw(a)
        assert set(v) == set(e.harness)
        # the same stream consumption as the catalog harness always had
        want = {p: float(b.uniform(lo, hi)) * (float(b.choice([-1.0, 1.0])) if s else 1.0)
                for p, (lo, hi, s) in e.harness.items()}
        assert v == want


def test_a_form_without_strengths_is_refused_by_name():
    e = get("higher_nbar")                               # not a default effect: none
    with pytest.raises(KeyError, match="higher_nbar has no form 'nope'"):
        e.draw(np.random.default_rng(0), "nope")


@pytest.mark.parametrize("form", [f.name for f in get("dephasing").forms_for()])
def test_dephasing_injection_is_the_model_of_its_form(form):
    e = get("dephasing")
    v = e.draw(np.random.default_rng(3), form)
    m = _model_values(e, v)
    t = np.array([0.5, 1.0, 1.7]) * GM.t_ref
    if m["during"] < 0.5:
        # on the final coherences: the same factors as the model's
        k_model = e.coherence(GM, m, t)
        k_sim = np.array([e.inject_coherence(_refs(e, v), x) for x in t]).T
        assert np.allclose(k_sim, k_model, rtol=1e-12)
        assert e.inject_engine(_refs(e, v), KW, 0.6) == KW
        return
    assert e.inject_coherence(_refs(e, v), GM.t_ref) is None
    kw = e.inject_engine(_refs(e, v), KW, 0.6)
    coef = e.knob_coefficients(GM, m, t)                 # rates G(t)/t of the model
    if m["beta"] == 1.0:
        assert 1 / kw["T2"] - 1 / KW["T2"] == pytest.approx(coef["dephasing.independent"][1])
        common = 0.0 if np.isinf(kw["T2_corr"]) else 1 / kw["T2_corr"]
        assert common == pytest.approx(coef["dephasing.common"][1], abs=1e-9)
    else:
        # a time profile accumulating the model's G(t) = (its rate at t) * t
        rate, rate_c, beta, t_ref = kw["dephasing_profile"]
        assert t_ref == GM.t_ref and beta == m["beta"]
        G = accumulated_dephasing(1.0, beta, t_ref, t)
        assert np.allclose(rate * G, coef["dephasing.independent"] * t)
        assert np.allclose(rate_c * G, coef["dephasing.common"] * t)


@pytest.mark.parametrize("form", ["offset", "linear"])
def test_gate_rate_injection_is_the_model_s_power_offset(form):
    e = get("gate_rate_miscalibration")
    v = e.draw(np.random.default_rng(4), form)
    A = np.array([0.4, 0.6, 0.8])
    sim = [e.inject_engine(_refs(e, v), KW, a)["power_error_db"] for a in A]
    assert np.allclose(sim, e.power_offset_db(GM, _model_values(e, v), A))
    if form == "linear":
        assert abs(sim[2] - sim[0]) > 0.05                # the slope is injected


def test_gate_rate_truth_is_restated_at_the_diagnosis_s_reference_amplitude():
    e = get("gate_rate_miscalibration")
    v = {"eps": 0.2, "slope": 1.0}
    sim_truth = {"config": {"gate_amplitudes": [0.4, 0.6, 0.8]}}
    at = e.truth(v, sim_truth, SimpleNamespace(gate=SimpleNamespace(A_ref=0.7)))
    # the power error at A = 0.7 is eps + slope * (0.7 - 0.6)
    assert at["rate_error"] == pytest.approx(10 ** (-0.3 / 20) - 1)


@pytest.mark.parametrize("form", ["during", "initial", "both"])
def test_heating_injection_is_the_model_s_knobs(form):
    e = get("motional_heating")
    v = e.draw(np.random.default_rng(5), form)
    kw = e.inject_engine(v, KW, 0.6)
    coef = e.knob_coefficients(GM, _model_values(e, v), np.array([GM.t_ref]))
    assert (kw["ndot"] - KW["ndot"]) / 1e3 == pytest.approx(coef["heating.ndot"])
    assert kw["nbar"] - KW["nbar"] == pytest.approx(coef["initial.nbar"])
    assert (coef["heating.ndot"] > 0) == (form != "initial")
    assert (coef["initial.nbar"] > 0) == (form != "during")


@pytest.mark.parametrize("form", ["total", "split"])
def test_preparation_injection_is_the_model_s_preparation(form):
    """The simulator's lab preparation error is all spectator (``prep_split`` 1)."""
    e = get("spam_offset")
    v = e.draw(np.random.default_rng(6), form)
    kw = e.inject_engine(v, KW, 0.6)
    lab = Prep(KW["p_prep"], 0.0, 5e-5, 5e-5)
    pr = e.preparation(GM, _model_values(e, v), lab)
    assert kw["p_prep"] == pytest.approx(pr.spectator)
    assert kw["p_flip"] == pytest.approx(pr.flip)
    assert (pr.flip > 0) == (form == "split")


def test_am_pm_forms_inject_the_model_s_phase_where_it_acts():
    e = get("am_pm_omitted")
    x = np.linspace(0.0, 1.0, 11).astype(complex)
    y = np.sin(0.5 * np.pi * x.real) + 0j                # a compressing curve, y(1) = 1
    post = e.inject_field({"dphi": 0.1, "dphi_x": 0.0}, y, x, 1e9, 1.0)
    aom = e.inject_field({"dphi": 0.0, "dphi_x": 0.1}, y, x, 1e9, 1.0)
    assert np.allclose(np.angle(post), 0.1 * np.abs(y) ** 2)       # ~ r^2 after the AOM
    assert np.allclose(np.angle(aom), 0.1 * np.abs(x) ** 2)        # ~ |x|^2 of the drive
    # the model: the aom form is the phase polynomial's |x|^2 coefficient
    _, cp = e.coefficients(None, {"dphi_x": 0.1}, np.zeros(3), np.zeros(1))
    assert cp[2] == pytest.approx(0.1)


def test_a_detector_of_either_form_reads_what_the_model_inverts():
    from dpdfit.analyses.diagnosis.effects.detector_nonlinearity import true_over_read
    e = get("detector_nonlinearity")
    p = np.linspace(0.0, 2.0, 41)
    for form in ("linear", "power"):
        v = e.draw(np.random.default_rng(7), form)
        k, q = v["k"], v.get("q", 1.0)
        read = e.inject_photodiode(v, p, 2.0)
        u = read / read.max()
        # the model's u is relative to the largest reading, 1 + k of the largest power's:
        # u_read = u (1 + k_model u^q) with k_model = k (1 + k)^q
        u_true = u * true_over_read(u, k * (1 + k) ** q, q) * (1 + k)
        assert np.allclose(u_true, p / 2.0, atol=1e-12), form
        # and its size is the reading error at full scale, k
        assert e.size_values(None, {e.key("k"): k * (1 + k) ** q, e.key("q"): q})[
            "k_det"][0] == pytest.approx(k, rel=1e-9)


@pytest.mark.parametrize("form", ["slow", "two_scales", "two_scales_delay"])
def test_a_slow_memory_leaves_a_constant_drive_as_calibrated(form):
    """The calibration runs drive a constant amplitude: the memory's steady state is in
    them, so a constant drive's field is the static one; a modulated one's is not."""
    e = get("aom_memory")
    v = e.injected(e.draw(np.random.default_rng(8), form))
    fs = 1e9
    x = np.full(4096, 0.7 + 0j)
    assert np.allclose(e.inject_field(v, x * 0.5, x, fs, 1.0), x * 0.5)
    t = np.arange(4096) / fs
    x = 0.7 * np.abs(np.sin(2 * np.pi * 2e5 * t)) + 0j
    assert np.max(np.abs(e.inject_field(v, x, x, fs, 1.0) - x)) > 1e-3


# ---------------------------------------------------------------- the stale table's forms
def _calibration(tmp_path, effects):
    cfg = dataclasses.replace(harness_config(SEED), trace_amplitudes=(0.5,), cal_points=101)
    truth = simulate_campaign(tmp_path, seed=SEED, config=cfg.inject(effects), progress=False,
                              include_gates=False)
    amp = pd.read_csv(tmp_path / "calibration_amplitude.csv")
    fits = {r: fit_amplitude(g.A, g.power, g.power_err, cfg.order).A_corr
            for r, g in amp.groupby("run", sort=False)}
    runs = list(fits)
    k = table_index(cfg)
    return truth, np.array([fits[r] for r in runs]), k, cfg


@pytest.fixture(scope="module")
def stale_null(tmp_path_factory):
    return _calibration(tmp_path_factory.mktemp("stale") / "null", {})


@pytest.mark.parametrize("form, values", [
    ("aom", {"drift": 0.03}),
    ("aom_all", {"gain": 0.04}),
    ("aom_profile", {"drift": 0.03, "kappa": 0.8, "tau_d": 1.0}),
    ("table", {"table": 0.03}),
])
def test_stale_forms_leave_their_own_calibration_signature(tmp_path, stale_null, form, values):
    """Runs after the table's (the day's) run move by the drift, as a calibration measures
    it (the gain's A_corr-like part is the opposite way), relaxing with the profile; the
    table's own calibration moves instead for the ``table`` form; the truth's y1_drift
    says by how much, in the diagnosis's terms."""
    e = get("stale_calibration")
    v = {**e.form_values(form), **values}
    truth, fit, k, cfg = _calibration(tmp_path / form, {"stale_calibration": v})
    _, fit0, _, _ = stale_null
    rel = fit / fit0 - 1                                  # the same noise, drift or not
    after = rel[k + 1:]
    y1 = e.truth(e.injected(v), truth)["y1_drift"]
    cal = truth["calibration"]
    if form == "table":
        assert np.allclose(rel, 0.0, atol=1e-9)
        # the table's run is of its own (noise, and the fit's error of ~1 % in A_corr)
        assert 0.015 < cal["lut_relative_A_corr"] < 0.045
        assert y1 == pytest.approx(1 / 1.03 - 1, rel=1e-6)
        return
    assert np.allclose(rel[:k + 1], 0.0, atol=1e-9)        # up to the table's run
    assert y1 == pytest.approx(cal["recording_y1_drift"])
    if form == "aom_all":
        assert -0.05 < y1 < -0.03 and np.all(after < -0.02)
        return
    assert y1 == pytest.approx(0.03, rel=1e-9)
    days = np.array([r["day"] for r in truth["calibration"]["amplitude_runs"]])
    rec = days[k] + cfg.recording_hours[0] / 24
    from dpdfit.analyses.diagnosis.effects.stale_calibration import drift_profile
    want = 0.03 * drift_profile(e.injected(v), days[k + 1:] - rec)
    assert np.allclose(after, want, atol=0.002), (after, want)
