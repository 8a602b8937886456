"""A fit's free parameters in one object each: name, value, bounds, scale, the bound flag
and the error, and the fitted result that carries them."""

from __future__ import annotations

import numpy as np
import pytest

from dpdfit.analyses.diagnosis.effects import get
from dpdfit.analyses.diagnosis.fitting.hypothesis_fit import fit_hypothesis
from dpdfit.analyses.diagnosis.model.parameters import Parameter, Parameters
from dpdfit.analyses.diagnosis.model.residuals import Problem
from dpdfit.analyses.diagnosis.observables.campaign import load_campaign
from tests.helpers.paths import ROOT

BUNDLED_CAMPAIGN = ROOT / "datasets" / "synthetic_campaign"


@pytest.fixture(scope="module")
def tone_prob():
    """The bundled campaign's problem, tone side only (a fit takes a fraction of a second)."""
    return Problem(load_campaign(BUNDLED_CAMPAIGN), with_gates=False)


def test_parameters_give_their_arrays_in_order_and_are_looked_up_by_name():
    pars = Parameters((Parameter("a", 0.5, 0.0, 1.0, 0.1),
                       Parameter("b.x", -2.0, -3.0, 3.0, 0.5)))
    assert pars.names == ("a", "b.x") and len(pars) == 2
    np.testing.assert_array_equal(pars.values, [0.5, -2.0])
    np.testing.assert_array_equal(pars.lower, [0.0, -3.0])
    np.testing.assert_array_equal(pars.upper, [1.0, 3.0])
    np.testing.assert_array_equal(pars.scales, [0.1, 0.5])
    assert pars["b.x"].scale == 0.5 and pars.index("b.x") == 1
    with pytest.raises(ValueError):
        pars.index("c")
    moved = pars.at([0.7, 1.0])
    np.testing.assert_array_equal(moved.values, [0.7, 1.0])
    np.testing.assert_array_equal(moved.lower, pars.lower)
    np.testing.assert_array_equal(moved.scales, pars.scales)
    np.testing.assert_array_equal(pars.values, [0.5, -2.0])
    with pytest.raises(ValueError):
        pars.at([0.7])


def test_an_optimum_on_a_bound_is_flagged_to_a_billionth_of_the_bound():
    pars = Parameters((Parameter("a", 0.5, 0.0, 1.0, 0.1),
                       Parameter("b", 0.0, -200.0, 200.0, 1.0)))
    on = pars.at_optimum([1e-10, 200.0 - 1e-7])
    assert [p.at_bound for p in on] == [True, True]
    assert list(on.values) == [1e-10, 200.0 - 1e-7]
    off = pars.at_optimum([1e-8, 200.0 - 1e-6])
    assert [p.at_bound for p in off] == [False, False]
    assert not any(p.at_bound for p in pars)


def test_a_fit_carries_each_free_parameter_with_its_catalog_bounds_value_and_error(tone_prob):
    f = fit_hypothesis(tone_prob, (("detector_nonlinearity", None),))
    e = get("detector_nonlinearity")
    assert f.free == f.parameters.names == ("detector_nonlinearity.k",)
    for i, par in enumerate(f.parameters):
        declared = e.param(par.name.split(".", 1)[1], tone_prob)
        assert (par.lo, par.hi, par.scale) == (declared.lo, declared.hi, declared.scale)
        assert par.value == f.params[par.name]
        assert not par.at_bound
        assert par.error == pytest.approx(np.sqrt(f.cov[i, i]), rel=1e-12)
        assert f.params_err[par.name] == par.error
    assert f.scales == (e.param("k", tone_prob).scale,)
    assert f.at_bound == ()
    # the form's fixed parameter is reported, but is not free and has no error
    assert "detector_nonlinearity.q" in f.params
    assert np.isnan(f.params_err["detector_nonlinearity.q"])
