"""Deviation search of standardised residuals (building block of the discrepancy diagnosis)."""

import numpy as np
import pytest

from dpdfit.errors import InputError
from dpdfit.analyses.diagnosis.evidence.deviations import deviating_intervals


@pytest.mark.slow
def test_false_alarm_rate_on_null_series_is_below_nominal():
    rng = np.random.default_rng(7)
    x = np.linspace(0.05, 1, 40)
    alarms = sum(bool(deviating_intervals(x, rng.standard_normal(40), alpha=0.05)) for _ in range(1000))
    assert alarms / 1000 <= 0.05        # Bonferroni: conservative


@pytest.mark.slow
def test_finds_and_localises_a_concealed_offset():
    rng = np.random.default_rng(8)
    x = np.linspace(0.05, 1, 40)
    hits, located = 0, 0
    for _ in range(200):
        z = rng.standard_normal(40)
        z[(x > 0.6) & (x < 0.85)] += 2.5            # a region that departs by 2.5 sigma
        dev = deviating_intervals(x, z)
        if dev:
            hits += 1
            d = dev[0]
            located += (d.lo > 0.5) and (d.hi < 0.95) and d.statistic > 0
    assert hits / 200 >= 0.95 and located / hits >= 0.9


def test_shape_labels():
    x = np.linspace(0, 1, 30)
    z = np.zeros(30)
    z[15:] = np.linspace(1, 8, 15)                 # grows with x
    d = deviating_intervals(x, z)[0]
    assert d.shape == "growing" and d.slope > 0
    z2 = np.zeros(30)
    z2[10:20] = 4.0
    d2 = deviating_intervals(x, z2)[0]
    assert d2.shape == "offset" and d2.offset == pytest.approx(4.0)
    assert d2.lo == pytest.approx(x[10]) and d2.hi == pytest.approx(x[19])


def test_more_series_means_less_significance():
    x = np.arange(20.0)
    z = np.zeros(20)
    z[5:9] = 3.0
    one = deviating_intervals(x, z)[0].significance_sigma
    many = deviating_intervals(x, z, n_series=50)[0].significance_sigma
    assert many < one


def test_bad_input():
    with pytest.raises(InputError, match="equal length"):
        deviating_intervals([1, 2], [1.0])
    with pytest.raises(InputError, match="finite"):
        deviating_intervals([1, 2], [1.0, np.nan])
    assert deviating_intervals([1.0], [5.0], min_points=2) == []
