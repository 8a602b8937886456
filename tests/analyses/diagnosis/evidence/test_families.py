"""A cause is a family of forms: family evidence, separation within the noise, nesting."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.analyses.diagnosis.evidence.families import (chi2_gap_z, family_evidence,
                                                         maximal_forms, nested)
from dpdfit.analyses.diagnosis.evidence.thresholds import NOISE_Z


def _fit(z: np.ndarray, n_par: int, key: str = "tones:R10") -> SimpleNamespace:
    """A fit whose residuals are ``z`` (one series), with ``n_par`` parameters."""
    z = np.asarray(z, dtype=float)
    chi2 = float(z @ z)
    return SimpleNamespace(chi2=chi2, n_par=n_par, n_obs=z.size, blocks=((key, z),),
                           chi2_by_observable={key: chi2})


def test_equal_forms_give_the_form_gain_and_one_form_pays_for_the_choice():
    rng = np.random.default_rng(1)
    ref = _fit(rng.normal(size=400) + 1.0, 2)
    good = rng.normal(size=400)
    fits = {"a": _fit(good, 3), "b": _fit(good, 3), "c": _fit(good, 3)}
    fe = family_evidence("x", ref, fits)
    g = fe.forms["a"][1]
    assert fe.gain == pytest.approx(g)                 # every form as good: no cost
    bad = _fit(rng.normal(size=400) + 1.0, 3)
    fe1 = family_evidence("x", ref, {"a": fits["a"], "b": bad, "c": bad})
    # one form carries the family: it pays 2 ln 3 for having been chosen among three
    assert fe1.gain == pytest.approx(g - 2 * np.log(3), abs=1e-6)
    assert fe1.best == "a"
    # forms not fitted count as giving no evidence (a lower bound)
    fe2 = family_evidence("x", ref, {"a": fits["a"]}, n_forms=3)
    assert fe2.gain == pytest.approx(fe1.gain, abs=1e-6)
    # the p-value is the best form's, Bonferroni over the forms
    one = family_evidence("x", ref, {"a": fits["a"]})
    assert fe2.p_value == pytest.approx(min(1.0, 3 * one.p_value))


def test_decisive_family_needs_the_gain_and_the_corrected_p_value():
    from dpdfit.analyses.diagnosis.evidence.families import FamilyEvidence
    fe = FamilyEvidence("x", gain=12.0, gain_raw=12.0, p_value=1e-4, best="a")
    assert fe.decisive(1, 10.0, 0.0027) and not fe.decisive(30, 10.0, 0.0027)
    assert not FamilyEvidence("x", 8.0, 8.0, 1e-9, "a").decisive(1, 10.0, 0.0027)


def test_chi2_gap_z_has_unit_scatter_when_two_forms_are_equally_far_from_the_truth():
    """Truth half-way between two fixed models: D = chi2_b - chi2_a scatters about 0 with
    variance 4 d.d, so |z| exceeds NOISE_Z about as often as a Gaussian does (the
    estimate counts the better fit's offset as misfit, so it can only be wider)."""
    rng = np.random.default_rng(7)
    n, reps = 200, 2000
    x = np.linspace(0, 1, n)
    delta = 0.15 * np.sin(3 * x)
    zs = []
    for _ in range(reps):
        noise = rng.normal(size=n)
        a, b = _fit(noise - delta / 2, 1), _fit(noise + delta / 2, 1)
        zs.append(np.sign(b.chi2 - a.chi2) * chi2_gap_z(a, b))
    zs = np.array(zs)
    assert abs(np.mean(zs)) < 0.1
    assert 0.8 < np.std(zs) < 1.1
    assert np.mean(np.abs(zs) > NOISE_Z) < 0.006


def test_chi2_gap_z_is_large_when_the_recordings_reject_a_form():
    rng = np.random.default_rng(8)
    n = 300
    noise = rng.normal(size=n)
    delta = 0.8 * np.cos(np.linspace(0, 4, n))
    assert chi2_gap_z(_fit(noise, 1), _fit(noise + delta, 1)) > 5
    same = _fit(noise, 1)
    assert chi2_gap_z(same, same) == 0.0


def test_a_misfit_along_the_difference_widens_the_noise_by_the_tempering():
    """The scatter of the gap is the tempered one: z = D / (2 sqrt(tau d.d)), tau the
    dispersion of the evidence (> 1 when the misfit follows the difference)."""
    from dpdfit.analyses.diagnosis.evidence.tempering import evidence_dispersion
    rng = np.random.default_rng(9)
    n = 400
    x = np.linspace(0, 1, n)
    e = 1.0 * np.cos(2 * np.pi * x) + rng.normal(size=n)
    d = 0.3 * np.cos(2 * np.pi * x)
    better, worse = _fit(e, 1), _fit(e + d, 1)
    tau = evidence_dispersion(better, worse)
    D = worse.chi2 - better.chi2
    assert tau > 3
    assert chi2_gap_z(better, worse) == pytest.approx(D / (2 * np.sqrt(tau * d @ d)),
                                                        rel=1e-9)


def test_chi2_gap_z_can_be_restricted_to_one_side():
    rng = np.random.default_rng(3)
    t = rng.normal(size=100)
    g = rng.normal(size=20)
    a = SimpleNamespace(chi2=float(t @ t + g @ g), blocks=(("tones:R10", t), ("gates:C", g)),
                        chi2_by_observable={"tones:R10": float(t @ t),
                                            "gates:C": float(g @ g)})
    g2 = g + 5.0
    b = SimpleNamespace(chi2=float(t @ t + g2 @ g2), blocks=(("tones:R10", t), ("gates:C", g2)),
                        chi2_by_observable={"tones:R10": float(t @ t),
                                            "gates:C": float(g2 @ g2)})
    assert chi2_gap_z(a, b) > 3
    assert chi2_gap_z(a, b, ("tones:", "runs:")) == 0.0


@pytest.mark.parametrize("name, maximal", [
    ("dephasing", ["stretched", "coherence_stretched"]),
    ("motional_heating", ["both"]),
    ("gate_rate_miscalibration", ["linear"]),
    ("detector_nonlinearity", ["power"]),
    ("am_pm_omitted", ["post", "aom_quartic"]),
    ("aom_memory", ["fast", "two_scales_delay"]),
    ("stale_calibration", ["aom_profile", "table"]),
])
def test_maximal_forms_follow_from_what_each_form_frees_and_fixes(name, maximal):
    forms = EFFECTS[name].forms_for()
    assert [f.name for f in maximal_forms(forms)] == maximal
    by = {f.name: f for f in forms}
    for f in forms:
        assert any(nested(f, by[m]) for m in maximal)
