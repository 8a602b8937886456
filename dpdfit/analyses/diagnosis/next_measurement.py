"""Which single further recording best separates the hypotheses still in reach.

When the diagnosis cannot decide between hypotheses (several catalog effects
fit about equally), or a named effect's size is poorly constrained (the caller
then passes the fit and the same fit with that parameter moved by its error),
:func:`propose_next_measurement` names the recording, from a menu a lab can
take, with the largest expected separation per unit of lab time.

Each item's mean is predicted under each hypothesis by the diagnosis's own
forward model at that hypothesis's fitted parameters (``FitResult.all_params``;
tone-side hypotheses re-predict the gates from their own field, the gate model
rebased as the diagnosis does), with the recording's noise:

* ``amplitude_run``: one more amplitude calibration run now (at the time of the
  latest run after the recordings, else right after them) in the run-to-run
  drift modes, predicted by the effects' ``run_drift``; sigma: the modes'
  run-to-run sd (the runs before the recordings' where known, else 1);
* ``phase_run``: one phase run on 101 amplitudes (``A >= PHASE_MIN_A``), the
  AOM's phase curve of the tone model (calibration modes, ``pm_x``, the effects'
  ``coefficients``); sigma: the campaign's learnt phase-run noise, else
  :data:`~dpdfit.core.defaults.PHASE_RUN_NOISE_RAD`;
* ``spectra``: traces at ``k`` (:data:`SPECTRA_COUNTS`) amplitudes of
  :data:`SPECTRA_GRID`, chosen greedily for the largest separation, with and
  without DPD, compared through the diagnosis's per-trace tone features; a
  tone's sigma is the learnt repeatability combined with the floor's part
  ``(10/ln 10) sqrt(2 N0/P)``, tones below ``MIN_SNR_DB`` unused, the absolute
  power scale (``gate_power``, a profiled nuisance) left out;
* ``populations`` / ``parity``: one scan at a recorded gate setting with the
  campaign's typical shots per scan point (parity: per phase, ``parity_phases``
  phases); ``F_pop`` and ``imb`` with their multinomial covariance, or ``C``
  with ``var = 2 (1 - 3 C^2/4) / N`` (cosine amplitude of a uniform phase scan),
  plus the scan's random power error (laser jitter and rate calibration
  through the gate model's responses);
* ``time_scan``: a scan at a recorded time-scan setting, its points, the
  campaign's typical shots per point, binomial ``P00`` and ``P11``.

The expected separation of hypotheses ``a`` and ``b`` is the Asimov ``delta
chi2 = sum(((m_a - m_b) / sigma)^2)`` over the new points, the expected delta
BIC the recording adds (it adds no parameters).  Parameters are held at their
fits: a refit to the new recording absorbs part of the difference, so this is
an upper-bound-like estimate.  With more than two hypotheses the smallest
separation of the first (the verdict's) from the others counts.  Choice: items
reaching :data:`~dpdfit.analyses.diagnosis.verdict.BIC_DECISIVE` first, then
the largest expected delta BIC per lab hour (:class:`~dpdfit.core.defaults.LabTimes`),
ties to the shorter.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.stats import norm

from dpdfit.analyses.diagnosis.measurement_menu import (BUILDERS, RUN_AMPLITUDES,
                                                        SPECTRA_COUNTS, SPECTRA_GRID,
                                                        Hypothesis)
from dpdfit.analyses.diagnosis.verdict import BIC_DECISIVE
from dpdfit.core.defaults import LAB_TIMES

__all__ = ["NextMeasurement", "propose_next_measurement", "decisive_target",
           "DECIDE_PROBABILITY", "KINDS", "SPECTRA_GRID",
           "SPECTRA_COUNTS", "RUN_AMPLITUDES"]

#: what a proposal may be
KINDS = ("amplitude_run", "phase_run", "spectra", "populations", "parity", "time_scan")
_KEYS = ("what", "settings", "expected_delta_bic", "separates", "lab_seconds", "per_hour")


@dataclass(frozen=True)
class NextMeasurement:
    """The proposed next recording (module doc), or none with the reason.

    Attributes
    ----------
    what : str or None
        One of :data:`KINDS`; None when no item could be built.
    settings : dict
        The recording's settings (e.g. ``{"amplitudes": [...], "dpd": [0, 1]}``).
    expected_delta_bic : float
        Expected delta BIC the recording adds between the hypotheses it separates
        (the smallest over the alternatives; an upper-bound-like estimate).
    separates : list of str
        ``FitResult.effect`` of the hypotheses, the verdict's first.
    lab_seconds, per_hour : float
        Lab time of the recording and expected delta BIC per lab hour.
    menu : list of dict
        Every item evaluated, with the keys above.
    reason : str or None
        Why nothing could be proposed.
    """

    what: str | None
    settings: dict = field(default_factory=dict)
    expected_delta_bic: float = 0.0
    separates: list = field(default_factory=list)
    lab_seconds: float = 0.0
    per_hour: float = 0.0
    menu: list = field(default_factory=list)
    reason: str | None = None

    def to_dict(self) -> dict:
        """The proposal as a JSON-ready dict: the keys of :attr:`menu`'s items plus
        ``menu``, or ``{"what": None, "reason": ...}`` when there is none."""
        if self.what is None:
            return {"what": None, "reason": self.reason}
        out = {k: getattr(self, k) for k in _KEYS}
        out["decisive"] = bool(self.reason is None)
        if self.reason:
            out["reason"] = self.reason
        out["menu"] = list(self.menu)
        return out

    def sentence(self) -> str:
        """One sentence for the report, e.g. ``"Next: spectra at A = 0.85, 0.95 with and
        without DPD (about 4 min) would separate a from b by an expected delta BIC of 35."``"""
        if self.what is None:
            return f"No next measurement proposed: {self.reason}."
        names = list(dict.fromkeys(self.separates))
        if len(names) == 1:
            goal = f"constrain the size of {names[0]}"
        else:
            goal = f"separate {names[0]} from {' and '.join(names[1:])}"
        return (f"Next: {_describe(self.what, self.settings)} (about "
                f"{_duration(self.lab_seconds)}) would {goal} by an expected delta BIC of "
                f"{_number(self.expected_delta_bic)}.")


#: probability with which the proposed recording should make the tempered delta BIC
#: decisive (``BIC_DECISIVE``) once taken
DECIDE_PROBABILITY = 0.95


def decisive_target(tempering: float = 1.0, probability: float = DECIDE_PROBABILITY
                    ) -> float:
    """The expected delta chi2 a recording must add so that its realised value, divided
    by the dispersion of the evidence ``tempering``, exceeds ``BIC_DECISIVE`` with
    ``probability``: the realised difference scatters about its expectation ``E`` with
    variance ``4 E tempering``, so ``E - z 2 sqrt(E tempering) = BIC_DECISIVE tempering``,
    ``E = tempering (z + sqrt(z^2 + BIC_DECISIVE))^2`` (27 for 95 % and no tempering)."""
    z = float(norm.ppf(probability))
    return float(tempering * (z + np.sqrt(z * z + BIC_DECISIVE)) ** 2)


def propose_next_measurement(prob, hypotheses: list, lab=None,
                             tempering: float = 1.0) -> NextMeasurement:
    """The single further recording that best separates ``hypotheses`` (module doc).

    Parameters
    ----------
    prob : dpdfit.analyses.diagnosis.problem.Problem
        The diagnosis's problem (campaign, tone and gate models, learnt noise).
    hypotheses : list of FitResult
        The verdict's fit first, then the alternatives; or a fit and the same
        hypothesis with a poorly constrained parameter moved by its error.
    lab : dpdfit.core.defaults.LabTimes, optional
        Lab time of each recording (default :data:`~dpdfit.core.defaults.LAB_TIMES`).
    tempering : float
        The dispersion of the evidence between the hypotheses (>= 1): the diagnosis
        divides the new recording's chi2 difference by about as much, so the
        recording must add that much more (:func:`decisive_target`).

    Returns
    -------
    NextMeasurement
        The best item and the whole menu; ``what=None`` with a reason when fewer
        than two hypotheses are given or no item can be predicted for the campaign.
    """
    lab = LAB_TIMES if lab is None else lab
    if len(hypotheses) < 2:
        return NextMeasurement(None, reason="fewer than two hypotheses to separate")
    hyps = [Hypothesis(prob, f) for f in hypotheses]
    separates = [f.effect for f in hypotheses]
    menu = []
    for build in BUILDERS:
        for what, settings, seconds, seps in build(prob, hyps, lab):
            delta = float(np.min(seps))
            menu.append({"what": what, "settings": settings, "expected_delta_bic": delta,
                         "separates": list(separates), "lab_seconds": float(seconds),
                         "per_hour": delta / (seconds / 3600.0)})
    if not menu:
        return NextMeasurement(None, reason=_why_none(prob))
    target = decisive_target(max(tempering, 1.0))
    menu = [_to_decisive(m, lab, target) for m in menu]
    best = max(menu, key=lambda m: (m["decisive"], -m["lab_seconds"] if m["decisive"]
                                    else m["per_hour"], -m["lab_seconds"]))
    if best["expected_delta_bic"] < target:
        best = {k: v for k, v in best.items() if k != "decisive"}
        return NextMeasurement(menu=menu, reason=(
            f"no recording of the menu separates them within "
            f"{_duration(lab.max_seconds)} of lab time: the best, {_describe(best['what'], best['settings'])}, "
            f"would give an expected delta BIC of {best['expected_delta_bic']:.2g}"), **best)
    return NextMeasurement(menu=menu, **{k: v for k, v in best.items() if k != "decisive"})


def _to_decisive(m: dict, lab, target: float = BIC_DECISIVE) -> dict:
    """Menu item ``m`` repeated until its expected delta BIC reaches ``target``
    (its separation grows with the repeats: independent runs, traces or scans, each
    with its own noise and power error), at most ``lab.max_seconds`` of lab time; the
    smallest unit when one already reaches it.  Spectra repeat their amplitudes (each
    recorded again at the same amplitude: repeated rows of ``spectra.csv``, pooled, so
    that the separation adds up)."""
    delta, secs = m["expected_delta_bic"], m["lab_seconds"]
    m = {**m, "decisive": bool(delta >= target)}
    if delta >= target or delta <= 0 or secs <= 0:
        return m
    k = int(min(np.ceil(target / delta), max(lab.max_seconds // secs, 1)))
    if k <= 1:
        return m
    st = dict(m["settings"])
    if m["what"] in ("amplitude_run", "phase_run"):
        st["runs"] = k * int(st.get("runs", 1))
    elif m["what"] == "spectra":
        st["amplitudes"] = sorted(list(st["amplitudes"]) * k)
    else:
        st["scans"] = k * int(st.get("scans", 1))
    return {**m, "settings": st, "expected_delta_bic": k * delta, "lab_seconds": k * secs,
            "per_hour": m["per_hour"], "decisive": bool(k * delta >= target)}


# ----------------------------------------------------------------- text
def _why_none(prob) -> str:
    """One line: why no item of the menu could be built for this campaign."""
    parts = ["no tone model (no spectra, no calibration runs to extend)"
             if getattr(prob, "tone", None) is None else "",
             "no gate settings" if getattr(prob, "gate", None) is None else ""]
    return ("no menu item can be predicted for this campaign: "
            + ("; ".join(filter(None, parts)) or "no recordings to extend"))


def _describe(what: str, s: dict) -> str:
    """The recording in words, e.g. ``"spectra at A = 0.85, 0.95 with and without DPD"``."""
    if what in ("amplitude_run", "phase_run"):
        n = int(s.get("runs", 1))
        if n > 1:
            return f"{n} more {what.split('_')[0]} calibration runs now"
        return {"amplitude_run": "one more amplitude calibration run now",
                "phase_run": "a phase calibration run"}[what]
    if what == "spectra":
        return f"spectra at A = {', '.join(f'{a:g}' for a in s['amplitudes'])} with and without DPD"
    at = f"at A = {s['A']:g} {'with' if s['dpd'] else 'without'} DPD"
    if s.get("scans", 1) > 1:
        at += f", {s['scans']} scans"
    if what == "time_scan":
        return f"a time scan {at} ({s['points']} points of {s['shots']} shots)"
    return f"a {'population' if what == 'populations' else 'parity'} scan {at} ({s['shots']} shots)"


def _number(x: float) -> str:
    return f"{x:.0f}" if abs(x) >= 10 else f"{x:.2g}"


def _duration(t: float) -> str:
    return f"{t:.0f} s" if t < 90 else f"{t / 60:.0f} min" if t < 5400 else f"{t / 3600:.1f} h"
