"""Waveforms, sampling grid, DPD application and exact tone powers of simulated fields."""

import numpy as np
import pytest

from dpdfit.errors import InputError
from dpdfit.models.spectrum import field_tone_powers, simulate_field
from dpdfit.models.waveforms import ToneSet, cardioid, sample_grid, synthesize
from dpdfit.simulation.aom_truth import truth_poly_tf

NU, XI0 = 1.84e6, 20e3


def test_cardioid_is_real_and_normalised():
    tones = cardioid()
    grid = sample_grid(NU, XI0, tones)
    w = synthesize(tones, grid, [0.2, 0.7])
    assert w.dtype == float and w.shape == (2, grid.n_samples)
    assert np.all(np.max(np.abs(w), axis=1) <= [0.2, 0.7])
    assert np.max(np.abs(w[1])) == pytest.approx(0.7, rel=2e-3)   # sampled peak ~ continuous peak


def test_every_tone_on_a_bin_and_powers_exact():
    tones = ToneSet((0, 1, 2, 3), (0.1, 1, -1, 0.05), (0.1, 1, -1, 0.05),
                    (0.3, 0, 0, -0.4), (0.3, 0, 0, -0.4))
    grid = sample_grid(NU, XI0, tones)
    w = synthesize(tones, grid, 1.0)
    spec = field_tone_powers(w, grid, (0, 1, 2, 3))
    scale = np.abs(spec.blue[1])
    assert np.allclose(np.abs(spec.blue) / scale, [0.1, 1, 1, 0.05], atol=1e-12)
    assert np.allclose(np.abs(spec.red) / scale, [0.1, 1, 1, 0.05], atol=1e-12)
    assert np.allclose(np.angle(spec.blue[[0, 3]]), [0.3, -0.4], atol=1e-12)
    # nothing else in the spectrum
    full = np.abs(np.fft.fft(w)) / grid.n_samples
    assert np.isclose(np.sum(full ** 2), np.sum(np.abs(spec.blue) ** 2 + np.abs(spec.red) ** 2))


def test_grid_refuses_aliasing_and_incommensurate_choices():
    tones = cardioid()
    with pytest.raises(InputError, match="aliases mixing products"):
        sample_grid(NU, XI0, tones, fs=20e6)
    with pytest.raises(InputError, match="not a ratio of integers"):
        sample_grid(NU * np.sqrt(2) / 1.4142, 5.6e3 * np.pi / 3, tones)
    with pytest.raises(InputError, match="integer number of samples"):
        sample_grid(NU, XI0, tones, fs=40.00001e6)
    g = sample_grid(1.84e6, 5.6e3, tones)           # 1.84e6/5.6e3 = 2300/7 -> 7 periods
    assert g.periods == 7
    assert g.fs > 2 * 9 * (1.84e6 + 3 * 5.6e3)


def test_dpd_linearises_am_only_model():
    """AM-only: f_AM(f_AM^-1(w)) = w below A_corr, so IM tones vanish with DPD."""
    tf = truth_poly_tf(with_phase=False)
    tones = cardioid()
    grid = sample_grid(NU, XI0, tones)
    A = np.array([0.3, 0.5])
    _, y_dpd = simulate_field(tf, tones, grid, A, dpd=True, am_only=True)
    _, y_raw = simulate_field(tf, tones, grid, A, dpd=False, am_only=True)
    s_dpd = field_tone_powers(y_dpd, grid).P_dB("blue")
    s_raw = field_tone_powers(y_raw, grid).P_dB("blue")
    assert np.all(s_dpd[:, 1] - s_dpd[:, 0] > 200)        # IM3 at numerical zero
    assert np.all(s_raw[:, 1] - s_raw[:, 0] < 60)         # clearly present without DPD
    # gate tone amplitude with DPD equals the ideal linear output
    ideal = field_tone_powers(synthesize(tones, grid, A), grid).P_dB("blue")
    assert np.allclose(s_dpd[:, 1], ideal[:, 1], atol=1e-9)


def test_tone_set_validation():
    with pytest.raises(InputError, match="distinct"):
        ToneSet((1, 1), (1, 1), (1, 1))
    with pytest.raises(InputError, match="Cardioid"):
        cardioid(2, 2)
    with pytest.raises(InputError, match="in \\[0, 1\\]"):
        synthesize(cardioid(), sample_grid(NU, XI0, cardioid()), 1.5)
