"""The detector linearity characterisation (``detector_linearity.csv``) as the diagnosis
reads it: each reading pair with the noise of each reading.

The noise of a reading is the photodiode's, which the calibration runs already measure:

* ``power``: its ``power_err`` when the file has the column;
* otherwise, and for ``power_attenuated`` always (the table gives no error of it): the
  calibration runs' noise at that reading -- the noise model learnt from every run
  (``sigma(P) = sqrt(a^2 + (b P)^2)``, :func:`~dpdfit.fits.photodiode.fit_power_noise`)
  when the calibration file has no ``power_err``; else the model run's recorded
  ``power_err`` at the same power (interpolated in the power); else (one run, no errors)
  the scatter of the model run about its fit, the same at every power.

:attr:`LinearityData.noise` says which.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from dpdfit.errors import DpdfitError
from dpdfit.fits.photodiode import PowerNoise
from dpdfit.recordings.campaign_folder import CampaignFolder

__all__ = ["LinearityData", "linearity_data", "calibration_power_noise",
           "campaign_power_noise"]


@dataclass(frozen=True)
class LinearityData:
    """The reading pairs: ``A, power, power_attenuated, transmission`` and each reading's
    1-sigma ``sigma``, ``sigma_attenuated`` (lab units), one row per pair; ``noise``:
    where the errors come from (module doc), one phrase."""

    table: pd.DataFrame
    noise: str

    def to_dict(self) -> dict:
        """The pairs' count and the noise's phrase (the table itself stays in the
        campaign's file)."""
        return {"pairs": int(len(self.table)), "noise": self.noise}


def calibration_power_noise(data, power_noise, amp_fit):
    """``(sigma(P), phrase)``: the calibration runs' noise of a reading ``P`` (module
    doc).  ``data``: the model amplitude run (``A, value, error``); ``power_noise``: the
    learnt :class:`~dpdfit.fits.photodiode.PowerNoise` or None; ``amp_fit``: its fit."""
    if power_noise is not None:
        return power_noise.sigma, (f"the calibration runs' learnt noise (sqrt(a^2 + (b P)^2), "
                                   f"{power_noise.n_runs} runs)")
    value = np.asarray(data.value, dtype=float)
    if data.error is not None:
        order = np.argsort(value)
        v, e = value[order], np.asarray(data.error, dtype=float)[order]
        return (lambda P: np.interp(P, v, e)), "the model run's power_err at the same power"
    s = float(np.std(value - amp_fit.power(np.asarray(data.A, dtype=float))))
    return (lambda P: np.full(np.shape(P), s)), "the model run's scatter about its fit"


def campaign_power_noise(camp):
    """``sigma(P)`` of a reading of the campaign ``camp``'s photodiode (a
    :class:`~dpdfit.analyses.diagnosis.observables.campaign.Campaign`): the noise model
    learnt from its runs, else its model run's (read again from its folder); None when
    the folder cannot be read."""
    learnt = (camp.calibration_noise or {}).get("photodiode")
    if learnt:
        return PowerNoise(**learnt).sigma
    try:
        data = CampaignFolder(camp.folder).amplitude_model
    except (DpdfitError, OSError):
        return None
    return calibration_power_noise(data, None, camp.amplitude)[0]


def linearity_data(table: pd.DataFrame | None, data, power_noise, amp_fit):
    """The :class:`LinearityData` of a validated ``detector_linearity.csv`` table
    (:func:`~dpdfit.recordings.detector_linearity.read_detector_linearity`), None
    without one."""
    if table is None:
        return None
    sigma, phrase = calibration_power_noise(data, power_noise, amp_fit)
    p = table["power"].to_numpy(dtype=float)
    pa = table["power_attenuated"].to_numpy(dtype=float)
    if "power_err" in table.columns:
        sp, which = table["power_err"].to_numpy(dtype=float), "power_err"
    else:
        sp, which = sigma(p), phrase
    out = pd.DataFrame({"A": table["A"].to_numpy(dtype=float), "power": p,
                        "power_attenuated": pa,
                        "transmission": table["transmission"].to_numpy(dtype=float),
                        "sigma": np.maximum(sp, 1e-300),
                        "sigma_attenuated": np.maximum(sigma(pa), 1e-300)})
    noise = (f"power: {which}; power_attenuated: {phrase}" if which == "power_err"
             else f"both readings: {phrase}")
    return LinearityData(out, noise)
