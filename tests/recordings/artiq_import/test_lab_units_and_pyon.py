"""PYON decoding of a run's expid and the unit rules of imported recordings."""

import math

import numpy as np
import pytest

from dpdfit.recordings.pyon import PyonError, decode_pyon
from dpdfit.recordings.units import UnitError, convert, stored_unit


def test_pyon_as_sipyco_writes_it():
    text = ('{"arguments": {"amplitude": 0.4, "dpd": true, "label": "P001", "none": null, '
            '"big": -inf, "bad": nan, "pair": (1, 2), "ndscan_params": "{\\"overrides\\": '
            '{}}"}, "class_name": "ParityScan", "log_level": 30}')
    v = decode_pyon(text)
    a = v["arguments"]
    assert a["amplitude"] == 0.4 and a["dpd"] is True and a["none"] is None
    assert a["big"] == -math.inf and math.isnan(a["bad"]) and a["pair"] == (1, 2)
    assert decode_pyon(a["ndscan_params"]) == {"overrides": {}}
    assert v["class_name"] == "ParityScan"


def test_pyon_never_evaluates_code():
    for text in ('__import__("os").system("true")', "open('x')", "[x for x in ()]",
                 "{1: lambda: 0}", "a.b"):
        with pytest.raises(PyonError):
            decode_pyon(text)


@pytest.mark.parametrize("shown,scale,stored", [("us", 1e-6, "s"), ("kHz", 1e3, "Hz"),
                                                ("deg", 1.0, "deg"), ("", 1.0, ""),
                                                ("mturn", 1e-3, "turn"), ("us", 2e-6, None)])
def test_stored_unit_from_the_shown_unit_and_its_scale(shown, scale, stored):
    assert stored_unit(shown, scale) == stored


def test_conversions_to_the_columns_units():
    assert convert([1e-5], "s", "t_us")[0] == pytest.approx(10.0, rel=1e-15)
    assert convert([3349.27], "Hz", "xi0_khz")[0] == pytest.approx(3.34927, rel=1e-15)
    assert convert([0.25], "turn", "phase_rad")[0] == pytest.approx(math.pi / 2, rel=1e-15)
    assert convert([90.0], "deg", "phase_rad")[0] == pytest.approx(math.pi / 2, rel=1e-15)
    assert convert([40.0], "%", "A")[0] == pytest.approx(0.4, rel=1e-15)
    assert convert([-6.0], "dBm", "A", full_scale_dbm=0.0)[0] == pytest.approx(10 ** -0.3)
    # the shown value comes back exactly when it was stored as shown * scale
    t_us = np.array([15.23546879, 0.1, 33.0])
    assert np.array_equal(convert(t_us * 1e-6, "s", "t_us"), (t_us * 1e-6) / 1e-6)


@pytest.mark.parametrize("unit,column", [("V", "t_us"), ("rad", "A"), ("kHz", "phase_rad"),
                                         ("dBm", "P_dB"), ("s", "n00")])
def test_units_of_another_dimension_are_refused(unit, column):
    with pytest.raises(UnitError, match="does not convert"):
        convert([1.0], unit, column)


def test_dbm_needs_the_full_scale_power():
    with pytest.raises(UnitError, match="full_scale_dbm"):
        convert([1.0], "dBm", "A")
