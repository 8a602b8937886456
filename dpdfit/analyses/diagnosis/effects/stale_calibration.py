"""``stale_calibration``: the predistortion table no longer matches the AOM.

The table was built from a calibration run; the AOM at the recordings is not
the AOM of that run.  Both are described in the run-to-run drift modes of the
campaign's amplitude runs (principal components of their curves, each scaled
to its run-to-run sd, at most ``MAX_DRIFT_MODES``; no dependence on the
polynomial order), so a drift of 1 is a typical day-to-day change.

* form ``aom`` (catalog): the AOM drifted since the table's run by ``sa_i``
  along its significant drift modes (today's transfer = the run's plus the
  modes) and stayed there;
* form ``aom_all``: the same along all ``MAX_DRIFT_MODES`` modes (a drift whose
  shape the campaign's typical drift does not quite have);
* form ``aom_profile``: along all modes, with a time profile: the runs taken ``dt``
  days after the recordings sit at ``sa_i f(dt)``,
  ``f(dt) = 1 - kappa (1 - exp(-dt / tau_d))`` (``kappa > 0``: it relaxes back,
  ``kappa < 0``: it keeps growing); needs the recording times
  (``campaign.json`` ``spectra_recorded``) and runs after them;
* form ``table``: the table belongs to another calibration than the records
  say (the AOM is the model's; the table's calibration is off by ``st_i``).

With the recording times, the calibration runs taken after the recordings
are data of every hypothesis (:mod:`dpdfit.analyses.diagnosis.model.residuals`): a
drifted AOM moves them (the ``aom`` forms predict by how much), a nonlinear
detector bends every run alike.

Priors: flat, ``|sa_i|, |st_i| <= 20`` sd; ``-3 <= kappa <= 1``;
``0.1 <= tau_d <= 200`` days.  Size: ``y1_drift``, the fractional change of
y(1) of the AOM since the table's run (``table``: today's y(1) over the table
calibration's); ``kappa`` and ``tau_d_days`` for the profile.
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.observables.calibration_drift import MAX_DRIFT_MODES

from .base import Effect, Form, Param

__all__ = ["StaleCalibration", "EFFECT", "drift_profile"]


def _modes(ctx):
    tm = getattr(ctx, "tone", ctx)
    m = getattr(tm, "drift_modes", None)
    return np.zeros((0, 7)) if m is None else np.asarray(m)


def _significant(ctx) -> int:
    tm = getattr(ctx, "tone", ctx)
    return int(getattr(tm, "drift_significant", MAX_DRIFT_MODES))


def drift_profile(v: dict, dt) -> np.ndarray:
    """The drift's time profile ``f(dt)`` (module doc), ``dt`` in days after the recordings."""
    dt = np.maximum(np.asarray(dt, dtype=float), 0.0)
    tau = max(v.get("tau_d", 1.0), 1e-6)
    return 1.0 - v.get("kappa", 0.0) * (1.0 - np.exp(-dt / tau))


class StaleCalibration(Effect):
    """A predistortion table that no longer matches the AOM: the AOM drifted along
    the campaign's drift modes since the table's run (forms ``aom``, ``aom_all``,
    ``aom_profile``), or the table belongs to another calibration (``table``)."""

    name = "stale_calibration"
    side = "tones"
    meaning = ("the predistortion table no longer matches the AOM: it drifted since the "
               "table's calibration run")
    main = "y1_drift"

    def parameters(self, ctx=None):
        m = MAX_DRIFT_MODES if ctx is None else len(_modes(ctx))
        return (tuple(Param(f"sa{i}", "sd", -20.0, 20.0, 0.0, 1.0,
                            f"AOM drift along run-to-run mode {i}") for i in range(m))
                + (Param("kappa", "1", -3.0, 1.0, 0.0, 0.1, "fraction of the drift relaxed"),
                   Param("tau_d", "days", 0.1, 200.0, 5.0, 2.0, "time scale of the profile"))
                + tuple(Param(f"st{i}", "sd", -20.0, 20.0, 0.0, 1.0,
                              f"table calibration off along mode {i}") for i in range(m)))

    @property
    def table_only(self):
        return tuple(f"st{i}" for i in range(MAX_DRIFT_MODES))

    def forms_for(self, ctx=None):
        m = MAX_DRIFT_MODES if ctx is None else len(_modes(ctx))
        k = min(m, MAX_DRIFT_MODES if ctx is None else _significant(ctx))
        sa = tuple(f"sa{i}" for i in range(m))
        st = tuple(f"st{i}" for i in range(m))
        zero_st = {x: 0.0 for x in st}
        zero_sa = {x: 0.0 for x in sa}
        forms = [Form("aom", sa[:k], {"kappa": 0.0, "tau_d": 5.0, **zero_st,
                                      **{x: 0.0 for x in sa[k:]}},
                      "the AOM drifted since the table's run and stayed")]
        # without a campaign: every form of the family (a campaign whose drift modes are
        # all significant has no aom_all)
        if k < m or ctx is None:
            forms.append(Form("aom_all", sa, {"kappa": 0.0, "tau_d": 5.0, **zero_st},
                              "the same along every drift mode", starts_from="aom"))
        if ctx is None or getattr(ctx, "runs_after", None) is not None:
            forms.append(Form("aom_profile", sa + ("kappa", "tau_d"), dict(zero_st),
                              "the drift relaxes or grows after the recordings",
                              starts_from="aom_all" if k < m else "aom",
                              extra_starts=({"kappa": 0.5, "tau_d": 3.0},
                                            {"kappa": -1.0, "tau_d": 10.0})))
        forms.append(Form("table", st, {"kappa": 0.0, "tau_d": 5.0, **zero_sa},
                          "the table belongs to another calibration than recorded"))
        return tuple(forms)

    def supports(self, ctx):
        return len(_modes(ctx)) > 0

    def _shift(self, modes, v, prefix):
        a = np.array([v.get(f"{prefix}{i}", 0.0) for i in range(len(modes))])
        return a @ modes if a.size else 0.0

    def coefficients(self, tm, v, cy, cp):
        modes = _modes(tm)
        if not any(v.get(f"sa{i}") for i in range(len(modes))):
            return cy, cp
        cy = cy.copy()
        cy[2:2 + modes.shape[1]] += self._shift(modes, v, "sa")
        return cy, cp

    def table_curve(self, tm, v, cy):
        modes = _modes(tm)
        if not any(f"st{i}" in v for i in range(len(modes))):
            return None
        # rebuilt even at st = 0, so the model is smooth in st for the Jacobian
        cy = cy.copy()
        cy[2:2 + modes.shape[1]] += self._shift(modes, v, "st")
        return cy

    def run_drift(self, ctx, v, days_after):
        modes = _modes(ctx)
        a = np.array([v.get(f"sa{i}", 0.0) for i in range(len(modes))])
        if not a.any():
            return None
        return drift_profile(v, days_after)[:, None] * a[None, :]

    def size_values(self, ctx, p):
        v = self.values(p) or {}
        modes = _modes(ctx)
        tm = getattr(ctx, "tone", ctx)
        y1 = tm.y_calibrated(1.0)
        k = np.arange(2, 2 + modes.shape[1])
        d_sa = float(self._shift(modes, v, "sa") @ np.ones(k.size)) if modes.size else 0.0
        d_st = float(self._shift(modes, v, "st") @ np.ones(k.size)) if modes.size else 0.0
        # today's y(1) over the table calibration's y(1), minus 1
        drift = (y1 + d_sa) / (y1 + d_st) - 1.0
        out = {"y1_drift": (drift, "1", "fractional change of y(1) since the table's run")}
        if "kappa" in v and v.get("kappa"):
            out["kappa"] = (v["kappa"], "1", "fraction of the drift relaxed (< 0: grew)")
            out["tau_d_days"] = (v.get("tau_d", 0.0), "days", "time scale of the profile")
        return out


EFFECT = StaleCalibration()
