"""Each form's injection moves the simulated recordings as the diagnosis's forward model
of that form predicts, for the same parameters, on a tiny campaign.

Tone side (fast): the exact tone powers of the simulated field, with and without the
injected form, against the tone model of the campaign (:class:`ToneModel`, its own
calibration) with and without the form's parameters.  Gate side (slow: the gate model's
engine responses): the simulator's noise-free populations and parity contrast at each
gate setting against the gate model's prediction.  The stale table's forms are
parametrised in the campaign's drift modes, not in the simulator's terms; their
calibration signatures are checked in ``tests/simulation/test_form_injection.py``."""

import dataclasses

import numpy as np
import pytest

import dpdfit.simulation.campaign.gate_runs as G
from dpdfit.analyses.diagnosis.observables.campaign import load_campaign
from dpdfit.analyses.diagnosis.model.tones.tone_model import TONE_HARMONICS, ToneModel
from dpdfit.models import gate_sim
from dpdfit.simulation.campaign import simulate_campaign
from dpdfit.simulation.campaign.calibration_runs import calibration_runs
from dpdfit.simulation.campaign.optics import dpd_lut, gate_spectrum, trace_field
from dpdfit.simulation.harness import harness_config
from dpdfit.simulation.injections import get

SEED = 4242
A = np.array([0.6, 0.9])                 # IM tones well above any floor, DPD or not
IM = np.isin(TONE_HARMONICS, (-1, 0, 3, 4))


def _tone_config():
    return dataclasses.replace(harness_config(SEED), trace_amplitudes=tuple(A), n_amp_runs=5,
                               runs_after_recordings=1, cal_points=101)


def _simulated_db(cfg):
    """Exact tone powers (dB) of the simulated field: (A, dpd, [red, blue], harmonic)."""
    _, _, aom, tf, _ = calibration_runs(cfg)
    lut = dpd_lut(tf, cfg.lut_points)
    n = np.asarray(TONE_HARMONICS)
    k = np.rint((cfg.nu + n * cfg.xi0_spec) / cfg.xi0_spec).astype(int)
    out = np.zeros((A.size, 2, 2, n.size))
    for i, a in enumerate(A):
        for d in (0, 1):
            y = trace_field(cfg, aom, lut, a, d)
            spec = np.fft.fft(y) / y.size
            out[i, d] = 20 * np.log10(np.abs([spec[-k % y.size], spec[k % y.size]]))
    return out


def _model_db(tmp, cfg, p):
    """The tone model of the campaign simulated with ``cfg`` at parameters ``p``."""
    simulate_campaign(tmp, seed=SEED, config=cfg, progress=False, include_gates=False)
    tm = ToneModel(load_campaign(tmp))
    return 20 * np.log10(np.abs(tm.tone_amplitudes(A, p)))


@pytest.fixture(scope="module")
def tone_null(tmp_path_factory):
    cfg = _tone_config()
    return _simulated_db(cfg), _model_db(tmp_path_factory.mktemp("tones") / "null", cfg, {})


def _model_params(name, v):
    e = get(name)
    inj = e.injected(v)
    if name == "detector_nonlinearity":
        # the model's k is relative to the largest reading: k (1 + k)^q of the truth's
        inj = {**inj, "k": inj["k"] * (1 + inj["k"]) ** inj["q"]}
    return {e.key(k): x for k, x in inj.items()}


@pytest.mark.parametrize("name, form", [
    (n, f.name) for n in ("am_pm_omitted", "aom_memory", "detector_nonlinearity",
                          "higher_order_im") for f in get(n).forms_for()])
def test_tone_side_form_moves_the_im_tones_as_the_model_predicts(tmp_path, tone_null, name,
                                                                  form):
    sim0, mod0 = tone_null
    e = get(name)
    v = e.draw(np.random.default_rng(21), form)
    cfg = _tone_config().inject({name: v})
    # the IM tones within 35 dB of the gate tones: the change of a tone far below them
    # in dB measures the static curve's last details, not the effect
    strong = IM & (sim0 > sim0.max() - 35.0)
    d_sim = (_simulated_db(cfg) - sim0)[strong]
    d_mod = (_model_db(tmp_path / "c", cfg, _model_params(name, v)) - mod0)[strong]
    assert np.max(np.abs(d_sim)) > 0.3, "the injection changes the IM tones"
    bad = np.abs(d_sim - d_mod) > 0.25 * np.abs(d_mod) + 0.1
    assert not bad.any(), (v, np.round(d_sim, 2), np.round(d_mod, 2))


# ---------------------------------------------------------------- gate side (slow)
GATE_EFFECTS = ("motional_heating", "dephasing", "spam_offset", "gate_rate_miscalibration")


@pytest.fixture(scope="module")
def gate_campaign(tmp_path_factory):
    """A tiny campaign (two gate amplitudes, one scan), its gate model, the simulator's
    gate tones of every setting, and its noise-free gates without any injection (the
    reference every form's change is taken from: simulated once, not once per form)."""
    from dpdfit.analyses.diagnosis.model.residuals import Problem
    cfg = dataclasses.replace(harness_config(SEED), gate_amplitudes=(0.4, 0.8),
                              time_scan_A=0.4, scan_shots=((300, 300),), time_scan_points=5,
                              trace_amplitudes=(0.2, 0.4, 0.6, 0.8), n_amp_runs=5,
                              runs_after_recordings=1, cal_points=41)
    folder = tmp_path_factory.mktemp("gates") / "c"
    truth = simulate_campaign(folder, seed=SEED, config=cfg, progress=False)
    gm = Problem(load_campaign(folder), effects=GATE_EFFECTS).gate
    _, _, aom, tf, _ = calibration_runs(cfg)
    lut = dpd_lut(tf, cfg.lut_points)
    spectra = {k: gate_spectrum(cfg, aom, lut, *k) for k in gm.keys}
    eta_Omega0 = truth["gates"]["eta_Omega0"]
    return cfg, gm, spectra, eta_Omega0, _simulated_gates(cfg, gm, spectra, eta_Omega0)


def _simulated_gates(cfg, gm, spectra, eta_Omega0):
    """Noise-free F_pop, imbalance and contrast at each setting (rows: the gate model's)."""
    refs = G._references(cfg, spectra, eta_Omega0)
    out = []
    for key in gm.keys:
        n, b, c = spectra[key]
        xi = gm.xi[key]
        r = gate_sim.simulate_setting(b, c, n, eta_Omega0, xi, parity_phases=G._PHASES,
                                      **G._engine(cfg, key[0], 0.0, refs),
                                      **G._after_gate(cfg, 1.0 / xi, refs))
        out.append((r.pop[0] + r.pop[2], r.pop[0] - r.pop[2], r.parity_fit()[0]))
    return np.array(out).T


@pytest.mark.slow
@pytest.mark.parametrize("name, form", [(n, f.name) for n in GATE_EFFECTS
                                        for f in get(n).forms_for()])
def test_gate_side_form_moves_the_gates_as_the_model_predicts(gate_campaign, name, form):
    cfg, gm, spectra, eO, null = gate_campaign
    e = get(name)
    v = e.draw(np.random.default_rng(22), form)
    d_sim = _simulated_gates(cfg.inject({name: v}), gm, spectra, eO) - null
    # the simulator's lab preparation error is all spectator: prep_split 1
    p0 = {"prep_split": 1.0, "e01": cfg.p_det, "e10": cfg.p_det}
    names = {q.name for q in e.parameters()}
    p = {**p0, **{e.key(k): x for k, x in e.injected(v).items() if k in names}}
    m, m0 = gm.predict(p), gm.predict(p0)
    d_mod = np.array([m[q] - m0[q] for q in ("F_pop", "imb", "C")])
    assert np.max(np.abs(d_sim)) > 3e-3, "the injection changes the gates"
    largest = np.max(np.abs(d_mod))
    for obs, s, mo in zip(("F_pop", "imb", "C"), d_sim, d_mod):
        if np.max(np.abs(mo)) < 2e-3:
            assert np.max(np.abs(s)) < 2e-3, (obs, s, mo)
            continue
        # a side effect of the form, not its signature (e.g. the contrast's second-order
        # response to a power offset: a few 1e-3 of either sign, differing in detail)
        if np.max(np.abs(mo)) < 0.25 * largest:
            continue
        ratio = (s @ mo) / (mo @ mo)              # the simulator's change along the model's
        if form == "stretched" and obs == "C":
            # the model treats G(t)/t as a constant rate; slow noise acts late in the gate,
            # where it costs the contrast more (tests/models/test_slow_dephasing.py)
            assert 1.0 < ratio < 2.0, (obs, s, mo)
        else:
            assert 0.7 < ratio < 1.4, (obs, s, mo)
