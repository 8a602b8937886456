"""How the simulator injects ``stale_calibration``: one physical drift per form.

Injection values, all relative:

* ``aom``: ``drift`` of the AOM's ``A_corr`` (its amplifier's compression, the
  campaign's own run-to-run drift direction) since the table's run, staying;
* ``aom_all``: ``gain``, a drift of the RF gain ahead of the AOM
  (:class:`~dpdfit.simulation.aom_truth.BraggAOM` ``rf_gain``), staying: its
  curve is about -1.65 times an ``A_corr`` drift plus a shape of its own (up to
  0.2 % of y for a 2 % gain drift) that the run-to-run drift does not have;
* ``aom_profile``: ``drift`` with the time profile ``f(dt)`` of the effect
  (:func:`~dpdfit.analyses.diagnosis.effects.stale_calibration.drift_profile`;
  ``kappa``, ``tau_d``) for the runs after the recordings;
* ``table``: ``table``, the table's calibration is of the AOM with ``A_corr``
  off by this fraction (an unrecorded run; the AOM itself did not drift).

The harness's strengths are 1-3 % (``drift``, ``table``: a typical day-to-day
drift of ``A_corr`` is 1.6 %) and 1.5-4 % (``gain``, whose ``A_corr``-like part
is then 1.2-3.3 %); the profile relaxes or grows by 40-90 % over 1-4 days.
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.effects.stale_calibration import EFFECT, drift_profile

from .base import Injection

__all__ = ["StaleCalibrationInjection", "INJECTION"]


class StaleCalibrationInjection(Injection):
    """A drift of the AOM's ``A_corr`` or of its RF gain since the table's run (with a
    profile after the recordings), or a table from another calibration."""

    effect = EFFECT
    harness = {"drift": (0.01, 0.03, True)}
    harness_forms = {"aom_all": {"gain": (0.015, 0.04, True)},
                     "aom_profile": {"drift": (0.01, 0.03, True), "kappa": (0.4, 0.9, True),
                                     "tau_d": (1.0, 4.0, False)},
                     "table": {"table": (0.01, 0.03, True)}}
    strength = ("drift", "1", "relative change of the AOM's A_corr at the recordings since "
                "the table's calibration run")

    def _since_table(self, v, d, days_after_table, days_after_recording):
        """A drift ``d`` since the table's run, with the profile after the recordings."""
        after = np.asarray(days_after_recording, dtype=float)
        out = np.where(after >= 0, d * drift_profile(v, after), 0.0)
        return np.where(np.asarray(days_after_table) > 0, out, 0.0)

    def inject_aom(self, v, days_after_table, days_after_recording):
        return self._since_table(v, v.get("drift", 0.0), days_after_table,
                                 days_after_recording)

    def inject_rf_gain(self, v, days_after_table, days_after_recording):
        return self._since_table(v, v.get("gain", 0.0), days_after_table,
                                 days_after_recording)

    def inject_table(self, v):
        return float(v.get("table", 0.0))

    def injected(self, v):
        # gain and table only when injected: a drift's truth.json keeps its keys
        return {"drift": float(v.get("drift", 0.0)), "kappa": float(v.get("kappa", 0.0)),
                "tau_d": float(v.get("tau_d", 5.0)),
                **{k: float(v[k]) for k in ("gain", "table") if v.get(k)}}

    def injection_params(self):
        return ("drift", "kappa", "tau_d", "gain", "table")

    def truth(self, v, sim_truth, ctx=None):
        """Today's y(1) (as a calibration run measures it) over that of the table's
        calibration, minus 1: the simulator's drift at the recordings, and for the
        ``table`` form the table's calibration off by ``table``."""
        cal = sim_truth.get("calibration", {})
        today = float(cal.get("recording_y1_drift", v.get("drift", 0.0)))
        table = float(v.get("table", 0.0))
        return {"y1_drift": (1.0 + today) / (1.0 + table) - 1.0 if table else today}


INJECTION = StaleCalibrationInjection()
