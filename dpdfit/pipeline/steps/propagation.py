"""Step ``propagation`` of ``dpdfit analyze``: the calibration's uncertainty pushed into F_est.

The emcee posterior of the predistortion table's amplitude run is sampled
once (from the calibration step's fit of that run) and the drift model is
built from the calibration step's fits of every run; both are handed to
:func:`~dpdfit.analyses.propagation.propagate` (10^4 draws at A = 0.5, for a
fresh and a 30-day-old table) and
:func:`~dpdfit.analyses.propagation.threshold_distribution`, and the same
posterior is drawn in the corner plot.  -> ``propagation.json``.
"""

from __future__ import annotations

from dataclasses import dataclass

from dpdfit.analyses.propagation import PropagationResult, propagate, threshold_distribution
from dpdfit.core.defaults import AMPLITUDE_ORDER
from dpdfit.fits.drift import calibration_uncertainty
from dpdfit.fits.posterior import sample_amplitude_posterior
from dpdfit.recordings.calibration_runs import list_runs
from dpdfit.report.posterior_plots import CORNER_DPI, corner_figure

from ..context import Context
from .calibration import CalibrationFits

__all__ = ["propagation_step", "PropagationResults", "AgedPropagation",
           "propagation_summary"]

#: seed of the posterior chain and of the predictive draws
_SEED = 1
#: fidelity loss for the recalibration answer
_RECALIBRATION_LOSS = 1e-4
#: predictive draws of the threshold distributions
_THRESHOLD_DRAWS = 1000
_LEVELS = ("1e-2", "1e-3", "1e-4")
_FLAGS = ("dpd", "no_dpd")


def _corner_posterior(df, fits: CalibrationFits, posterior):
    """The table run's posterior at the calibration's order K: the propagation's when K is
    its order, else sampled here."""
    amp = fits.calibration.amplitude
    if amp.order == AMPLITUDE_ORDER:
        return posterior
    run = amp.source.get("run")
    sub = df[df["run"] == run] if run else df
    return sample_amplitude_posterior(
        sub["A"].to_numpy(float), sub["power"].to_numpy(float),
        sub["power_err"].to_numpy(float) if "power_err" in sub.columns else None,
        amp.order, seed=_SEED)


def _corner(posterior) -> dict:
    """The corner plot as ``analyze`` writes it: ``figS_posterior_corner.png``."""
    return {"figS_posterior_corner": corner_figure(posterior)}


@dataclass(frozen=True)
class AgedPropagation:
    """The propagation for a predistortion table ``stale_days`` old: the F_est draws
    (:class:`~dpdfit.analyses.propagation.PropagationResult`) and the threshold
    efficiencies' distribution (:func:`~dpdfit.analyses.propagation.threshold_distribution`)."""

    stale_days: float
    result: PropagationResult
    thresholds: dict

    @property
    def key(self) -> str:
        """Its key in ``propagation.json`` and ``summary.json``: ``"stale_days=D"``."""
        return f"stale_days={self.stale_days:g}"

    def to_dict(self) -> dict:
        """Its entry of ``propagation.json``: the result's dict with its ``thresholds``."""
        return {**self.result.to_dict(), "thresholds": self.thresholds}


def _propagate(ctx: Context, unc, phase, A, stale_days, draws) -> tuple:
    """An :class:`AgedPropagation` per table age D in ``stale_days``."""
    camp = ctx.meta
    model = dict(nu=camp["nu_hz"], xi0=camp["xi0_spectra_hz"], nbar=camp["nbar_assumed"],
                 eta_ref=camp["eta_ref"])
    results = [propagate(unc.posterior, A, stale_days=d, draws=draws, phase=phase,
                         drift=unc.drift, seed=_SEED, recalibration_loss=_RECALIBRATION_LOSS,
                         **model) for d in stale_days]
    return tuple(AgedPropagation(float(d), r, threshold_distribution(
        unc.posterior, stale_days=d, draws=_THRESHOLD_DRAWS, phase=phase, drift=unc.drift,
        seed=_SEED, **model)) for d, r in zip(stale_days, results))


def propagation_step(ctx: Context, fits: CalibrationFits | None, A=0.5,
                     stale_days=(0.0, 30.0), draws=10000):
    """MCMC posterior of the day's calibration and the drift of y(1), pushed into F_est(A)."""
    cf, res = ctx.campaign, ctx.results
    if fits is None or not cf.has("calibration_amplitude.csv"):
        res.status("propagation", "skipped", "needs the calibration runs")
        return None
    df = cf.amplitude_runs
    if len(list_runs(df)) < 2:
        res.status("propagation", "skipped", "drift needs >= 2 calibration runs")
        return None
    # the propagation's order is AMPLITUDE_ORDER whatever the campaign's order
    unc = calibration_uncertainty(df, AMPLITUDE_ORDER, fits.calibration.amplitude.source.get("run"),
                                  seed=_SEED, fits=fits.amplitude_fits(AMPLITUDE_ORDER))
    if ctx.figures is not None:
        ctx.figure(_corner, _corner_posterior(df, fits, unc.posterior), dpi=CORNER_DPI)
    out = PropagationResults(by_age=_propagate(ctx, unc, fits.calibration.phase, A,
                                               stale_days, draws), A=A, draws=draws)
    res.json_file("propagation.json", out.to_dict())
    res.status("propagation", "ok", f"A = {A:g}, {draws} posterior draws, stale "
                                    + ", ".join(f"{d:g}" for d in stale_days) + " days")
    return out


@dataclass(frozen=True)
class PropagationResults:
    """What the propagation step made at amplitude ``A``: one :class:`AgedPropagation`
    per table age, in the order of ``stale_days``."""

    by_age: tuple
    A: float
    draws: int

    @property
    def stale_days(self) -> tuple:
        """The table ages (days), in order."""
        return tuple(a.stale_days for a in self.by_age)

    def to_dict(self) -> dict:
        """``propagation.json``: ``{"stale_days=D": entry}`` per table age."""
        return {a.key: a.to_dict() for a in self.by_age}


def propagation_summary(p: PropagationResults) -> dict:
    """The ``propagation`` section of ``summary.json``: the table ages (``stale_days``,
    days, in the order of ``results``), F_est quantiles and the threshold efficiencies'
    medians per table age, the chain of the last age."""
    by_age = {a.key: a.to_dict() for a in p.by_age}
    last = by_age[p.by_age[-1].key]
    return {"A": p.A, "draws": p.draws, "stale_days": list(p.stale_days), "results": {
        k: {flag: {q: v[flag][q] for q in ("F_est_median", "F_est_q2.5", "F_est_q97.5")}
            for flag in _FLAGS} for k, v in by_age.items()},
        "tau": last.get("tau"), "n_independent": last.get("n_independent"),
        "thresholds": {k: {flag: {lev: v["thresholds"][flag][lev].get("median")
                                  for lev in _LEVELS}
                           for flag in _FLAGS} for k, v in by_age.items()}}
