"""The diagnosis takes the calibration runs' noise models from the calibration step.

Without ``power_err``/``phase_err`` the noise of the recorded powers and phases is
learnt from every calibration run (:mod:`dpdfit.fits.photodiode`).  ``analyze``'s
calibration step does that once (``CalibrationFits.noise``, ``.phase_noise``); the
diagnosis is handed those models instead of refitting every run, with identical
results.
"""

import shutil

import pandas as pd
import pytest

import dpdfit.fits.photodiode as photodiode
from dpdfit.analyses.diagnosis.diagnose import diagnose
from dpdfit.analyses.diagnosis.observables.campaign import load_campaign
from dpdfit.pipeline.context import Context, Results
from dpdfit.pipeline.steps import calibration_step
from dpdfit.recordings.campaign_folder import CampaignFolder
from tests.helpers.paths import ROOT

CAMPAIGN = ROOT / "datasets" / "synthetic_campaign"


@pytest.fixture(scope="module")
def no_errors(tmp_path_factory):
    """The bundled campaign without power_err and phase_err: the noise is learnt."""
    camp = tmp_path_factory.mktemp("no_errors") / "campaign"
    shutil.copytree(CAMPAIGN, camp)
    for name, col in (("calibration_amplitude.csv", "power_err"),
                      ("calibration_phase.csv", "phase_err")):
        df = pd.read_csv(camp / name)
        df.drop(columns=col).to_csv(camp / name, index=False)
    return camp


def _counting(monkeypatch) -> dict:
    calls = {"power": 0, "phase": 0}
    for key, name in (("power", "fit_power_noise"), ("phase", "fit_phase_noise")):
        original = getattr(photodiode, name)

        def counted(*a, _k=key, _f=original, **kw):
            calls[_k] += 1
            return _f(*a, **kw)
        monkeypatch.setattr(photodiode, name, counted)
    return calls


def test_diagnosis_uses_the_calibration_steps_noise_models_with_identical_results(
        no_errors, monkeypatch):
    ctx = Context(campaign=CampaignFolder(no_errors), results=Results(), formula="exact",
                  figures=None)
    fits = calibration_step(ctx)
    assert fits.noise is not None and fits.phase_noise is not None
    given = dict(run_fits=fits.amplitude_fits(fits.order), calibration=fits.calibration)
    calls = _counting(monkeypatch)
    learnt_here = load_campaign(CampaignFolder(no_errors), **given)
    assert calls == {"power": 1, "phase": 1}
    handed = load_campaign(CampaignFolder(no_errors), **given,
                           noise=(fits.noise, fits.phase_noise))
    assert calls == {"power": 1, "phase": 1}          # no run refitted for the noise
    assert handed.calibration_noise == learnt_here.calibration_noise
    pd.testing.assert_frame_equal(handed.amp_residuals, learnt_here.amp_residuals,
                                  check_exact=True)
    pd.testing.assert_frame_equal(handed.phase_residuals, learnt_here.phase_residuals,
                                  check_exact=True)
    a = diagnose(learnt_here, effects=(), pairs=0, progress=False)
    b = diagnose(handed, effects=(), pairs=0, progress=False)
    assert a.redchi_before == b.redchi_before
    assert a.baseline.chi2 == b.baseline.chi2
    assert a.extra["null_model"] == b.extra["null_model"]
