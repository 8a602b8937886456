"""Reading a campaign fits each amplitude run once: the drift modes take the runs' fits
the power noise's learning made (the same data, no errors, the campaign's order), and
give exactly what fitting the runs again gives."""

import shutil

import numpy as np
import pandas as pd

from dpdfit.analyses.diagnosis.observables import calibration_drift
from dpdfit.analyses.diagnosis.observables.campaign import load_campaign
from dpdfit.fits import photodiode
from tests.helpers.bundled_data import CAMPAIGN


def _without_power_errors(tmp_path):
    """The bundled campaign with its amplitude runs' ``power_err`` column dropped (the
    errors are then learnt from the runs)."""
    folder = tmp_path / "campaign"
    shutil.copytree(CAMPAIGN, folder)
    path = folder / "calibration_amplitude.csv"
    pd.read_csv(path, dtype=str).drop(columns="power_err").to_csv(path, index=False)
    return folder


def test_the_drift_modes_reuse_the_noise_fits_exactly(tmp_path, monkeypatch):
    folder = _without_power_errors(tmp_path)
    fitted = []
    real = calibration_drift.fit_amplitude

    def counting(*a, **kw):
        fitted.append(1)
        return real(*a, **kw)

    monkeypatch.setattr(calibration_drift, "fit_amplitude", counting)
    reused = load_campaign(folder)
    assert reused.calibration_noise["photodiode"] is not None     # the noise was learnt
    assert fitted == []                                           # no run fitted again
    fresh = load_campaign(folder, run_fits={})                    # every run refitted
    assert len(fitted) > 3
    assert np.array_equal(reused.drift_modes, fresh.drift_modes)
    assert reused.drift_significant == fresh.drift_significant
    a, b = reused.runs_after, fresh.runs_after
    assert (a is None) == (b is None)
    if a is not None:
        assert all(np.array_equal(getattr(a, k), getattr(b, k))
                   for k in ("days", "coords", "mu", "sd"))


def test_the_noise_learning_hands_out_the_fits_it_made():
    rng = np.random.default_rng(0)
    A = np.tile(np.linspace(0.0, 1.0, 21), 4)
    runs = np.repeat(["a", "b", "c", "d"], 21)
    P = np.sin(np.pi * A / 2) ** 2 + rng.normal(0, 1e-3, A.size)
    fits = {}
    noise = photodiode.fit_power_noise(A, P, runs, 5, fits)
    assert noise == photodiode.fit_power_noise(A, P, runs, 5)
    assert sorted(fits) == ["a", "b", "c", "d"]
    sel = runs == "b"
    want = photodiode.fit_amplitude(A[sel], P[sel], None, 5)
    assert np.array_equal(fits["b"].coefficients, want.coefficients)
