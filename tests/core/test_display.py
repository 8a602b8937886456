"""Results that display themselves: golden text/HTML renderings, and every
public result class has ``__str__``, ``__repr__``, ``_repr_html_``, ``report`` and ``to_dict``.

The golden files in ``tests/golden/`` pin ``repr(result)`` plus
``result.display_text()`` (``<name>.txt``) and ``result._repr_html_()``
(``<name>.html``) of a few results built deterministically from the bundled
data.  Numbers there have fixed significant digits (``dpdfit.core.display``),
so they are stable across platforms.  After an intended change of the
rendering, regenerate them with::

    DPDFIT_UPDATE_GOLDEN=1 python -m pytest tests/core/test_display.py

and review the diff of ``tests/golden/`` before committing.
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

import dpdfit
from dpdfit.analyses.budget.result import BudgetResult
from dpdfit.analyses.diagnosis.result import Diagnosis
from dpdfit.analyses.diagnosis.evidence.deviations import Deviation
from dpdfit.analyses.propagation.result import PropagationResult
from dpdfit.analyses.stability.result import StabilityResult
from dpdfit.core.display import Displayable, format_value_error
from dpdfit.fits.alignment import AlignmentFit
from dpdfit.fits.calibration import (AmplitudeCalibration, Calibration, PhaseCalibration,
                                     calibrate_amplitude)
from dpdfit.fits.counts.parity_fit import ParityFit, fit_parity
from dpdfit.fits.counts.pooling import merge_parity
from dpdfit.fits.counts.population import PopulationFidelity
from dpdfit.fits.drift import DriftModel
from dpdfit.fits.photodiode import PhaseNoise, PowerNoise
from dpdfit.fits.polyfit import PolyFitResult, polyfit
from dpdfit.fits.posterior import PosteriorResult
from dpdfit.fits.tone_noise import NoiseFloor
from dpdfit.fits.tones.results import SidebandTones, TraceSpectrum
from dpdfit.models.fidelity import Estimate
from dpdfit.recordings.tables import read_calibration
from tests.helpers.bundled_data import AOM, CAMPAIGN
from tests.helpers.golden import check_golden

#: every public result class of dpdfit
RESULT_CLASSES = [PolyFitResult, AmplitudeCalibration, PhaseCalibration, Calibration,
                  AlignmentFit, PosteriorResult, DriftModel, PowerNoise, PhaseNoise, NoiseFloor,
                  PopulationFidelity, ParityFit, SidebandTones, TraceSpectrum, Estimate,
                  PropagationResult, BudgetResult, StabilityResult, Diagnosis, Deviation]


# -- results built from the bundled data ------------------------------------------------

@pytest.fixture(scope="module")
def amplitude():
    data = read_calibration(AOM / "calibration_amplitude.csv", "amplitude")
    return calibrate_amplitude(data, order_scan=range(5, 10))


@pytest.fixture(scope="module")
def poly():
    """Weighted polynomial fit of the bundled phase calibration (A >= 0.1)."""
    d = read_calibration(AOM / "calibration_phase.csv", "phase")
    use = d.A >= 0.1
    return polyfit(d.A[use], d.value[use], range(1, 6), sigma=d.error[use])


@pytest.fixture(scope="module")
def parity(bundled_campaign_folder):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        merged = merge_parity(bundled_campaign_folder.parity)
    g = merged[(merged["A"] == 0.5) & (merged["dpd"] == 1)]
    return fit_parity(g["phase_rad"].to_numpy(), g["n_even"].to_numpy(), g["shots"].to_numpy())


@pytest.fixture(scope="module")
def estimate():
    sp = pd.read_csv(CAMPAIGN / "spectra.csv")
    sel = sp[(sp["A"] == 0.5) & (sp["dpd"] == 1) & (sp["sideband"] == "red")
             & sp["n"].between(0, 3)].sort_values("n")
    return dpdfit.estimate(sel["P_dB"].to_numpy())


#: the fixture behind each golden file that is not named as the file
_GOLDEN_FIXTURE = {"alignment": "bundled_alignment"}


@pytest.mark.parametrize("name", ["amplitude", "poly", "alignment", "parity", "estimate"])
def test_golden_renderings(name, request):
    result = request.getfixturevalue(_GOLDEN_FIXTURE.get(name, name))
    check_golden(f"{name}.txt", repr(result) + "\n\n" + result.display_text())
    check_golden(f"{name}.html", result._repr_html_())


# -- every public result class ----------------------------------------------------------

@pytest.mark.parametrize("cls", RESULT_CLASSES, ids=lambda c: c.__name__)
def test_every_result_class_displays_itself(cls):
    assert issubclass(cls, Displayable)
    assert cls.__str__ is not object.__str__
    assert cls.__repr__ is Displayable.__repr__, "dataclass must be declared repr=False"
    for name in ("_repr_html_", "report", "to_dict", "display_text"):
        assert callable(getattr(cls, name, None)), name


def test_str_is_the_report_and_repr_is_short(amplitude, poly, bundled_alignment, parity,
                                              estimate):
    for r in (amplitude, poly, bundled_alignment, parity, estimate):
        assert str(r) == r.report()
        assert len(repr(r)) < 300 and "array(" not in repr(r) and "\n" not in repr(r)
        html = r._repr_html_()
        assert html.startswith("<table") and html.count("<table") == html.count("</table>")


def test_html_is_escaped():
    d = Deviation(lo=0.1, hi=0.2, n_points=3, statistic=4.0, p_global=1e-4,
                  significance_sigma=3.9, offset=1.0, slope=0.0, shape="<script>")
    html = d._repr_html_()
    assert "<script>" not in html and "&lt;script&gt;" in html
    assert "[[Deviation]]" in d.report() and str(d) == d.report()


def test_tables_as_frames(amplitude, poly, bundled_alignment, parity, estimate):
    assert list(amplitude.to_frame()["order"]) == [5, 6, 7, 8, 9]
    data = read_calibration(AOM / "calibration_amplitude.csv", "amplitude")
    frame = dpdfit.amplitude_order_table(data.A, data.value, data.error, range(5, 10),
                                         as_frame=True)
    assert isinstance(frame, pd.DataFrame) and frame.equals(amplitude.to_frame())
    assert list(poly.to_frame()["power"]) == [1, 2, 3, 4, 5]
    assert (len(bundled_alignment.to_frame()) == 10
            and "resid_v" in bundled_alignment.to_frame())
    pf = parity.to_frame()
    assert np.allclose(pf["parity_model"], parity.parity(pf["phase_rad"]))
    assert estimate.to_frame()["F_est"].iloc[0] == pytest.approx(float(estimate.F_est))


def test_value_rounded_to_its_error():
    assert format_value_error(3.40830230, 0.0270583) == ("3.408", "0.027")
    assert format_value_error(-1.2e-17, 1e-3) == ("0.0000", "0.0010")     # no noise digits
    assert format_value_error(0.999999987, 2.7e-8) == ("0.999999987", "0.000000027")
    assert format_value_error(1.0, 0.0) == ("1", "0")
