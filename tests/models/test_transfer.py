import numpy as np
import pytest

from dpdfit.errors import NotInvertibleError
from dpdfit.models.transfer import TransferFunction, predistortion_table
from dpdfit.simulation.aom_truth import truth_poly_tf


def test_forward_symmetries_and_clipping():
    tf = truth_poly_tf()
    x = np.linspace(-1.5, 1.5, 301)
    assert np.allclose(tf.f_am(-x), -tf.f_am(x), rtol=0, atol=0)
    assert np.allclose(tf.f_pm(-x), tf.f_pm(x), rtol=0, atol=0)
    assert np.all(tf.f_am(x[x > 1]) == tf.f_am(1.0))
    assert np.all(tf.f_pm(x[x > 1]) == tf.f_pm(1.0))
    assert tf.f_am(1.0) == pytest.approx(tf.A_corr, abs=1e-15)


def test_forward_model_am_pm():
    tf = truth_poly_tf()
    rng = np.random.default_rng(1)
    x = rng.uniform(0, 1.2, 200) * np.exp(1j * rng.uniform(-np.pi, np.pi, 200))
    y = tf.forward(x)
    assert np.allclose(np.abs(y), tf.f_am(np.abs(x)), atol=1e-15)
    dphi = np.angle(y * np.exp(-1j * np.angle(x)))
    assert np.allclose(dphi, tf.f_pm(np.abs(x)), atol=1e-14)
    y_am = tf.forward(x, am_only=True)
    assert np.allclose(np.angle(y_am * np.exp(-1j * np.angle(x))), 0, atol=1e-14)
    # real negative envelope: field is negative real for AM-only (odd f_AM)
    assert tf.forward(np.array([-0.3]), am_only=True)[0].real == pytest.approx(tf.f_am(-0.3))


def test_inverse_round_trip_accuracy():
    tf = truth_poly_tf()
    t = np.linspace(0, tf.A_corr, 200001)
    x = tf.inverse_am(t)
    err = np.max(np.abs(tf.f_am(x) - t))
    assert err <= 1e-12
    assert np.all(np.diff(x) >= 0)
    assert x[0] == 0.0


def test_inverse_clamps_beyond_A_corr_and_is_odd():
    tf = truth_poly_tf()
    t = np.array([tf.A_corr, tf.A_corr + 1e-9, 0.8, 1.0])
    assert np.all(tf.inverse_am(t) == 1.0)
    s = np.array([-0.3, -0.1, 0.1, 0.3])
    assert np.allclose(tf.inverse_am(s), -tf.inverse_am(-s))


def test_not_invertible_names_amplitude():
    # y = A - 2 A^2 + 1.25 A^3: y' = (1 - 2.5 A)(1 - 1.5 A), local max y(0.4) = 0.16
    # below A_corr = y(1) = 0.25 -> no inverse on [0, A_corr]
    tf = TransferFunction((1, 2, 3), (1.0, -2.0, 1.25))
    with pytest.raises(NotInvertibleError) as exc:
        tf.inverse_am([0.1])
    assert exc.value.amplitude == pytest.approx(0.4, abs=1e-9)
    assert "dy/dA <= 0 at A = 0.400000" in str(exc.value)
    with pytest.raises(NotInvertibleError):
        predistortion_table(tf, 11)


def test_rolloff_after_peak_is_invertible_but_not_strict():
    # y = A - 0.5 A^2 + 0.07 A^3... build a curve peaking at 0.9 above y(1)
    # y' = (1 - A/0.9)(1 + cA) integrate: choose y' = 1 - A/0.9 -> y = A - A^2/1.8
    tf = TransferFunction((1, 2), (1.0, -1 / 1.8))
    Ac = tf.A_corr  # y(1) = 0.4444; peak y(0.9) = 0.45
    a_star, rolloff = tf.invertibility()
    assert rolloff and rolloff[0][0] == pytest.approx(0.9)
    assert tf.y(a_star) == pytest.approx(Ac, abs=1e-15) and a_star < 0.9
    t = np.linspace(0, Ac, 5001)
    assert np.max(np.abs(tf.f_am(tf.inverse_am(t)) - t)) <= 1e-12
    with pytest.raises(NotInvertibleError, match="dy/dA <= 0 at A = 0.9"):
        tf.inverse_am(t, strict=True)


def test_predistortion_table_grid():
    tf = truth_poly_tf()
    target, rf, clamped = predistortion_table(tf, 101)
    assert target[0] == 0 and target[-1] == 1 and len(rf) == 101
    assert np.all(rf[clamped] == 1.0)
    assert np.all(np.abs(tf.f_am(rf[~clamped]) - target[~clamped]) <= 1e-12)
