"""Which single further recording best separates the causes still in reach.

When the diagnosis cannot decide between hypotheses (families of the catalog
that explain the recordings about equally), or a named effect's size is poorly
constrained (the caller then passes the fit and the same fit with that parameter
moved by its error), :func:`propose_next_measurement` names the recording, from a
menu a lab can take (:mod:`~dpdfit.analyses.diagnosis.proposal.menu`), that
separates them in the least lab time.

Each item's values are predicted under each hypothesis by the diagnosis's own
forward model (tone-side hypotheses re-predict the gates from their own field),
with the recording's noise:

* ``amplitude_run``: one more amplitude calibration run now, in the run-to-run
  drift modes (the effects' ``run_drift``); sigma: the modes' run-to-run sd;
* ``phase_run``: one more phase calibration run now, after the recordings, the phase
  each hypothesis's phase transfer predicts at the model's run's amplitudes (``A >= PHASE_MIN_A``);
  sigma: the runs' learnt noise with their run-to-run drift of ``phi``, as the diagnosis
  fits such runs (:mod:`~dpdfit.analyses.diagnosis.model.phase_runs_block`); offered
  when the campaign has a phase calibration with errors and recording times;
* ``spectra``: traces at ``k`` (:data:`SPECTRA_COUNTS`) amplitudes of
  :data:`SPECTRA_GRID`, chosen greedily, with and without DPD, through the
  per-trace tone features (the learnt repeatability, which the settings state as
  ``tone_sd_db``, with the floor's part; the absolute scale ``gate_power`` left out);
* ``populations`` / ``parity``: one scan at a recorded gate setting with the
  campaign's typical shots (parity: per phase, ``parity_phases`` phases), with
  the scan's random power error;
* ``time_scan``: a scan at a recorded time-scan setting, binomial ``P00`` and ``P11`` at
  its ``points`` times after the start (the start, ``t = 0``, is not fitted);
* ``spam``: the SPAM characterisation, ``|00>`` and ``|11>`` prepared and detected with no
  gate (``spam.csv``), multinomial ``P00`` and ``P11`` of each; offered with gate
  recordings;
* ``pulse_response``: the AOM pulse response, a step to the gate's amplitude traced by a
  fast photodiode (``pulse_response.csv``), normalised to its settled level, each sample
  with the photodiode's relative noise; offered with the spectra;
* ``ramsey``: the Ramsey and spin-echo characterisation (``ramsey.csv``), both
  sequences at a scan of waits to 1.5 times the stated T2, multinomial ``P00`` and
  ``P11`` of each point; offered with gate recordings;
* ``detector_linearity``: the calibration photodiode read with and without a calibrated
  attenuator at each of ``points`` drives (``detector_linearity.csv``), the attenuated
  readings with the calibration runs' photodiode noise of both readings;
* ``thermometry``: sideband thermometry after a variable wait (``thermometry.csv``), the
  probed ion's binomial bright count after each wait and sideband; offered with gate
  recordings.

**Separating causes, not curves.**  A hypothesis is a group of fits: a family in
each of its forms still in reach.  For two hypotheses, ``a`` true and ``b`` its
rival, the rival's parameters are refitted to ``a``'s predicted recording
together with the recordings so far (T-optimality, Atkinson & Fedorov 1975;
KL-optimality for counts, Lopez-Fidalgo, Tommasi & Trandafir 2007).  Linearised,
with ``d`` the whitened difference of the predictions on the new recording,
``J`` the rival's whitened Jacobian there and ``F`` its information from the
recordings so far (the inverse of its fit's covariance; the calibration's error
modes with their posterior), the expected separation of ``k`` independent
repeats is

    ``d_k^T (I + J_k F^-1 J_k^T)^-1 d_k = k d.d - k^2 g^T (F + k J^T J)^-1 g``,
    ``g = J^T d``

(Woodbury).  It is taken in both directions and is the minimum over the forms
of both hypotheses: a recording must separate every form of one from every form
of the other.  Parameters held at their fits give ``k d.d``
(``separation_fixed``), which a refit can only lower.  The best
:data:`CONFIRMED` candidates are then confirmed by an exact refit of the rival
(a nonlinear least-squares fit of its parameters to the predicted recording,
the recordings so far entering through their information).

Each item is repeated (more runs, traces at the same amplitudes, more scans, each
with its own noise) until the tempered delta BIC it is expected to add is decisive
with 95 % probability (:func:`decisive_target`), within a working day of lab
time.  Choice: the shortest item that decides; else the largest expected delta
BIC per lab hour (:class:`~dpdfit.core.defaults.LabTimes`), ties to the shorter.

**Predictions that hold.**  The expected figure ranks the menu; it does not promise.
The chosen recording is simulated under each hypothesis of its binding pair
(:mod:`~dpdfit.analyses.diagnosis.proposal.replicates`: parameters drawn from their
covariance, noise, both hypotheses refitted), and it is called decisive only when the
10th percentile of the separations achieved decides (:func:`decisive_threshold`) under
whichever of the two is true.  Where the replicates cannot be drawn (no covariance,
or the parameters held), the expected figure decides, and ``replicates`` says so.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.stats import norm

from dpdfit.analyses.diagnosis.evidence.thresholds import BIC_DECISIVE
from dpdfit.analyses.diagnosis.proposal.expected_separation import (REFIT_NFEV, directions,
                                                                    separation)
from dpdfit.analyses.diagnosis.proposal.hypotheses import (RUN_AMPLITUDES, SPECTRA_GRID,
                                                           Hypothesis)
from dpdfit.analyses.diagnosis.proposal.menu import BUILDERS, SPECTRA_COUNTS
from dpdfit.analyses.diagnosis.proposal.replicates import (REPLICATES, replicate_separations,
                                                           summary)
from dpdfit.core.defaults import LAB_TIMES
from dpdfit.core.records import Record

__all__ = ["NextMeasurement", "propose_next_measurement", "decisive_target",
           "decisive_threshold",
           "DECIDE_PROBABILITY", "KINDS", "SPECTRA_GRID", "SPECTRA_COUNTS",
           "RUN_AMPLITUDES", "CONFIRMED", "REFIT_NFEV", "SATURATION_SHARE",
           "describe_recording", "replicated_clause"]

#: what a proposal may be
KINDS = ("amplitude_run", "phase_run", "spectra", "populations", "parity", "time_scan",
         "spam", "pulse_response", "ramsey", "detector_linearity", "thermometry")
_KEYS = ("what", "settings", "expected_delta_bic", "separates", "lab_seconds", "per_hour")
#: the best candidates whose expected separation is confirmed by an exact refit
#: (:meth:`~dpdfit.analyses.diagnosis.proposal.expected_separation.Direction.refit`, at most
#: :data:`~dpdfit.analyses.diagnosis.proposal.expected_separation.REFIT_NFEV` evaluations)
CONFIRMED = 3


@dataclass(frozen=True)
class NextMeasurement(Record):
    """The proposed next recording (module doc), or none with the reason.

    Attributes
    ----------
    what : str or None
        One of :data:`KINDS`; None when no item could be built.
    settings : dict
        The recording's settings (e.g. ``{"amplitudes": [...], "dpd": [0, 1]}``).
    expected_delta_bic : float
        Expected delta chi2 the recording adds between the hypotheses it separates,
        with the rival refitted (the smallest over the alternatives, both directions
        and every pair of forms).
    separates : list of str
        ``FitResult.effect`` of the hypotheses, the verdict's first.
    lab_seconds, per_hour : float
        Lab time of the recording and expected delta BIC per lab hour.
    menu : list of dict
        Every item evaluated, with the keys above.
    reason : str or None
        Why nothing could be proposed, or why the proposal does not decide.
    separation : dict
        The proposal's expected separation: ``fixed`` (parameters held at their
        fits), ``linearised`` and ``refit`` (the rival refitted; None when it was
        not confirmed).
    hypotheses : list
        Per hypothesis the forms in reach it stands for, ``[{"effects", "forms"}]``:
        what a later diagnosis refits to measure the separation achieved.
    binding : dict
        The pair and direction that set the separation: ``truth`` and ``rival`` (as
        in ``hypotheses``), each with ``expected_delta_bic``, the separation expected if
        it is the true one (the truth's is the binding, smaller one).
    replicates : dict
        The recording simulated under each hypothesis of the binding pair
        (:mod:`~dpdfit.analyses.diagnosis.proposal.replicates`): ``basis``
        (``"replicates"``, or ``"expected_delta_bic"`` when they could not be drawn,
        with ``why``), ``needed`` (the realised delta chi2 that decides,
        :func:`decisive_threshold`) and ``truth`` and ``rival`` (as in ``binding``, the
        one taken true), each ``{"median", "p10", "n"}`` of the separations achieved.
    """

    what: str | None
    settings: dict = field(default_factory=dict)
    expected_delta_bic: float = 0.0
    separates: list = field(default_factory=list)
    lab_seconds: float = 0.0
    per_hour: float = 0.0
    menu: list = field(default_factory=list)
    reason: str | None = None
    separation: dict = field(default_factory=dict)
    hypotheses: list = field(default_factory=list)
    binding: dict = field(default_factory=dict)
    replicates: dict = field(default_factory=dict)

    @property
    def decisive(self) -> bool | None:
        """Whether the recording is expected to decide (None when nothing is proposed):
        its expected separation reaches :func:`decisive_target` and, where the
        replicates were drawn, their 10th percentile reaches :func:`decisive_threshold`
        under either hypothesis of the binding pair."""
        return None if self.what is None else self.reason is None

    @classmethod
    def from_dict(cls, d: dict) -> "NextMeasurement":
        """The proposal of its JSON (:meth:`to_dict`), e.g. of an earlier diagnosis."""
        if not d.get("what"):
            return cls(None, reason=d.get("reason"))
        return cls(d["what"], **{k: d[k] for k in _KEYS[1:] if k in d},
                   menu=list(d.get("menu") or []), reason=d.get("reason"),
                   separation=dict(d.get("predicted_separation") or {}),
                   hypotheses=list(d.get("hypotheses") or []),
                   binding=dict(d.get("binding") or {}),
                   replicates=dict(d.get("replicates") or {}))

    def to_dict(self) -> dict:
        """The proposal as a JSON-ready dict: the keys of :attr:`menu`'s items plus
        ``menu``, ``decisive``, ``predicted_separation``, ``hypotheses``, ``binding`` and
        ``replicates``, or ``{"what": None, "reason": ...}`` when there is none."""
        if self.what is None:
            return {"what": None, "reason": self.reason}
        out = {k: getattr(self, k) for k in _KEYS}
        out["decisive"] = bool(self.reason is None)
        if self.reason:
            out["reason"] = self.reason
        out["menu"] = list(self.menu)
        if self.separation:
            out["predicted_separation"] = dict(self.separation)
        if self.hypotheses:
            out["hypotheses"] = list(self.hypotheses)
        if self.binding:
            out["binding"] = dict(self.binding)
        if self.replicates:
            out["replicates"] = dict(self.replicates)
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
        return (f"Next: {describe_recording(self.what, self.settings)} (about "
                f"{_duration(self.lab_seconds)}) would {goal} by an expected delta BIC of "
                f"{_number(self.expected_delta_bic)}{replicated_clause(self.replicates)}.")


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


def decisive_threshold(tempering: float = 1.0) -> float:
    """The realised delta chi2 that decides at the dispersion of the evidence
    ``tempering``: ``BIC_DECISIVE * tempering``.

    :func:`decisive_target` asks of the *realised* difference that, divided by the
    tempering (>= 1) as the diagnosis divides it, it exceed ``BIC_DECISIVE``, and turns
    that into the *expectation* that does so with 95 % probability under a Gaussian
    scatter.  The replicates sample the realised difference itself, so their percentile is
    compared with that same condition, ``BIC_DECISIVE * tempering`` (10 at no
    tempering), not with :func:`decisive_target`, which would count the scatter twice."""
    return float(BIC_DECISIVE * max(tempering, 1.0))


def propose_next_measurement(prob, hypotheses: list, lab=None,
                             tempering: float = 1.0, profile: bool = True
                             ) -> NextMeasurement:
    """The single further recording that best separates ``hypotheses`` (module doc).

    Parameters
    ----------
    prob : dpdfit.analyses.diagnosis.model.residuals.Problem
        The diagnosis's problem (campaign, tone and gate models, learnt noise).
    hypotheses : list
        The verdict's first, then the alternatives: each a FitResult, or a list of
        FitResults (the hypothesis's forms in reach; every pair of forms must be
        separated).  Or a fit and the same hypothesis with a poorly constrained
        parameter moved by its error (then ``profile=False``).
    lab : dpdfit.core.defaults.LabTimes, optional
        Lab time of each recording (default :data:`~dpdfit.core.defaults.LAB_TIMES`).
    tempering : float
        The dispersion of the evidence between the hypotheses (>= 1): the diagnosis
        divides the new recording's chi2 difference by about as much, so the
        recording must add that much more (:func:`decisive_target`), and its simulated
        recordings reach :func:`decisive_threshold` in 9 of 10.
    profile : bool
        Refit the rival to the predicted recording (default); False holds every
        parameter at its fit (e.g. to pin down one hypothesis's parameter).

    Returns
    -------
    NextMeasurement
        The best item and the whole menu; ``what=None`` with a reason when fewer
        than two hypotheses are given or no item can be predicted for the campaign.
    """
    lab = LAB_TIMES if lab is None else lab
    if len(hypotheses) < 2:
        return NextMeasurement(None, reason="fewer than two hypotheses to separate")
    groups = [[Hypothesis(prob, f) for f in (g if isinstance(g, (list, tuple)) else [g])]
              for g in hypotheses]
    separates = [g[0].fit.effect for g in groups]
    labels = [[h.label for h in g] for g in groups]
    target = decisive_target(max(tempering, 1.0))
    needed = decisive_threshold(tempering)
    cands = _ranked_candidates(prob, groups, lab, target, separates, profile)
    if not cands:
        return NextMeasurement(None, reason=_why_none(prob))
    best = cands[0]
    m = best["entry"]
    sep = {"fixed": best["fixed"], "linearised": best["linearised"],
           "refit": best.get("refit")}
    reps = _replicated(best, needed, profile)
    common = dict(menu=[c["entry"] for c in best["menu"]], separation=sep,
                  hypotheses=labels, binding=_binding(best), replicates=reps)
    fields = {k: m[k] for k in _KEYS}
    return NextMeasurement(**fields, **common,
                           reason=_short_of(m, target, needed, reps, lab))


def _ranked_candidates(prob, groups, lab, target, separates, profile) -> list:
    """Every item of the menu as a candidate, the best first, the best
    :data:`CONFIRMED` confirmed by an exact refit; each carries the whole menu in its
    original order (``"menu"``)."""
    cands = []
    for build in BUILDERS:
        for item in build(prob, [g[0] for g in groups], lab):
            dirs = directions(item, groups, profile)
            cands.append(_candidate(item, dirs, lab, target, separates))
    confirmed = set()
    order = []
    while cands:
        order = sorted(range(len(cands)), key=lambda i: _rank_key(cands[i]), reverse=True)
        todo = [i for i in order[:CONFIRMED] if i not in confirmed]
        if not todo:
            break
        for i in todo:
            cands[i] = _confirm(cands[i], lab, target)
            confirmed.add(i)
    return [{**cands[i], "menu": cands} for i in order]


def _short_of(m: dict, target: float, needed: float, reps: dict, lab) -> str | None:
    """Why the best recording ``m`` does not decide (None when it does): its expected
    delta BIC short of ``target``, or 1 in 10 of its simulated recordings short of
    ``needed``."""
    if m["expected_delta_bic"] < target:
        return (f"no recording of the menu separates them within "
                f"{_duration(lab.max_seconds)} of lab time: the best, "
                f"{describe_recording(m['what'], m['settings'])}, would give an expected "
                f"delta BIC of {_number(m['expected_delta_bic'])}, short of the "
                f"{_number(target)} that decides at this fit's misfit")
    low = _lowest_p10(reps)
    if low is not None and low < needed:
        return (f"the best recording of the menu, {describe_recording(m['what'], m['settings'])}, "
                f"would give an expected delta BIC of {_number(m['expected_delta_bic'])}, but 1 "
                f"in 10 of its simulated recordings (parameters drawn, both hypotheses "
                f"refitted) gives {_number(low)} or less, short of the {_number(needed)} that "
                f"decides at this fit's misfit")
    return None


def _reverse(c: dict, d):
    """The direction of candidate ``c`` reverse to ``d`` (its rival taken true), or None."""
    return next((r for g in c["dirs"] for r in g
                 if r.item is d.item and r.truth is d.rival and r.rival is d.truth), None)


def _replicated(c: dict, needed: float, profile: bool) -> dict:
    """The candidate's recording simulated under each hypothesis of its binding pair
    (:func:`~dpdfit.analyses.diagnosis.proposal.replicates.replicate_separations`), as
    :attr:`NextMeasurement.replicates`; the basis ``"expected_delta_bic"`` with ``why``
    when the replicates cannot be drawn."""
    def fallback(why: str) -> dict:
        return {"basis": "expected_delta_bic", "why": why}
    d = c["binding"]
    if d is None:
        return fallback("no pair binds the separation")
    if not profile:
        return fallback("the hypotheses' parameters are held at their fits (a size to "
                        "pin down)")
    out = {}
    for side, x in (("truth", d), ("rival", _reverse(c, d))):
        if x is None:
            out[side] = None
            continue
        try:
            s = replicate_separations(x, c["k"], REPLICATES)
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
            return fallback(f"the simulated recordings failed: {type(exc).__name__}: {exc}")
        if s is None:
            return fallback("a hypothesis has no covariance to draw its parameters from")
        out[side] = summary(s)
        if out[side] is None:
            return fallback("the simulated recordings gave no finite separation")
    return {"basis": "replicates", "needed": needed, **out}


def _lowest_p10(reps: dict) -> float | None:
    """The smaller 10th percentile of the two sides' replicates (whichever hypothesis is
    true, the recording must decide), or None when they were not drawn."""
    if reps.get("basis") != "replicates":
        return None
    p = [s["p10"] for s in (reps.get("truth"), reps.get("rival")) if s]
    return min(p) if p else None


def replicated_clause(reps: dict) -> str:
    """`` (at least 14 in 9 of 10 simulated recordings)``: the 10th percentile of the
    replicates where they were drawn (the smaller side's), else ``""``."""
    low = _lowest_p10(reps or {})
    return "" if low is None else (f" (at least {_number(low)} in 9 of 10 simulated "
                                   f"recordings)")


def _binding(c: dict) -> dict:
    """The binding pair of candidate ``c``, each hypothesis with the separation expected
    if it is the true one (``expected_delta_bic``: the binding direction's, and the
    reverse direction's at the same repeats, refitted where the candidate was): a
    recording is judged against the prediction for the hypothesis that turns out true."""
    d = c["binding"]
    if d is None:
        return {}
    rev = _reverse(c, d)
    k = c["k"]

    def value(x):
        return float(x.refit(k)) if c.get("refit") is not None else float(x.linearised(k)[0])
    return {"truth": {**d.truth.label, "expected_delta_bic": value(d)},
            "rival": {**d.rival.label,
                      "expected_delta_bic": None if rev is None else value(rev)}}


def _rank_key(c: dict) -> tuple:
    m = c["entry"]
    dec = m["expected_delta_bic"] >= c["target"]
    return (dec, -m["lab_seconds"] if dec else m["per_hour"], -m["lab_seconds"])


#: a recording that cannot decide is repeated until it has this share of what a working
#: day of it would give (a separation that saturates -- repeats of a gate setting share
#: its rate error -- is not worth a day)
SATURATION_SHARE = 0.95


def _repeats(dirs, unit_seconds: float, lab, target: float) -> int:
    """The fewest repeats whose linearised separation reaches ``target``, at most a
    working day of lab time (short of it, the fewest that give
    :data:`SATURATION_SHARE` of the day's); one when nothing separates."""
    k_max = int(max(lab.max_seconds // unit_seconds, 1)) if unit_seconds > 0 else 1
    top = separation(dirs, k_max)[0]
    if top <= 0:
        return 1
    lo, hi = 1, k_max
    if top < target:
        target = SATURATION_SHARE * top
    while lo < hi:                       # the separation grows with k: bisect
        mid = (lo + hi) // 2
        if separation(dirs, mid)[0] >= target:
            hi = mid
        else:
            lo = mid + 1
    return lo


def _repeat_settings(what: str, settings: dict, k: int) -> dict:
    """``settings`` repeated ``k`` times: more runs or scans; spectra repeat their
    amplitudes, each recorded again at the same amplitude (repeated rows of
    ``spectra.csv``, pooled)."""
    st = dict(settings)
    if k <= 1:
        return st
    if what in ("amplitude_run", "phase_run"):
        st["runs"] = k * int(st.get("runs", 1))
    elif what == "spectra":
        st["amplitudes"] = sorted(list(st["amplitudes"]) * k)
    else:
        st["scans"] = k * int(st.get("scans", 1))
    return st


def _candidate(item, dirs, lab, target, separates) -> dict:
    """One menu entry: the item repeated until it decides (linearised separation)."""
    k = _repeats(dirs, item.seconds, lab, target)
    lin, binding = separation(dirs, k)
    fixed = separation(dirs, k, "fixed")[0]
    return {"item": item, "dirs": dirs, "k": k, "linearised": lin, "fixed": fixed,
            "binding": binding, "target": target,
            "entry": _entry(item, k, lin, fixed, separates, target)}


def _entry(item, k, sep, fixed, separates, target) -> dict:
    secs = k * item.seconds
    return {"what": item.what, "settings": _repeat_settings(item.what, item.settings, k),
            "expected_delta_bic": float(sep), "separates": list(separates),
            "lab_seconds": float(secs),
            "per_hour": float(sep / (secs / 3600.0)) if secs > 0 else 0.0,
            "decisive": bool(sep >= target), "separation_fixed": float(fixed)}


def _confirm(c: dict, lab, target: float) -> dict:
    """The candidate's separation confirmed by an exact refit of the rival (module doc);
    repeated further (once) when the refit falls short of ``target``."""
    item, dirs, k = c["item"], c["dirs"], c["k"]
    exact, binding = separation(dirs, k, "refit")
    if c["linearised"] >= target > exact > 0:
        k_max = int(max(lab.max_seconds // item.seconds, 1))
        k2 = int(min(k_max, np.ceil(k * target / exact)))
        if k2 > k:
            k = k2
            exact, binding = separation(dirs, k, "refit")
    lin = separation(dirs, k)[0]
    fixed = separation(dirs, k, "fixed")[0]
    return {**c, "k": k, "linearised": lin, "fixed": fixed, "refit": exact,
            "binding": binding,
            "entry": {**_entry(item, k, exact, fixed, c["entry"]["separates"], target),
                      "separation_linearised": float(lin)}}


# ----------------------------------------------------------------- text
def _why_none(prob) -> str:
    """One line: why no item of the menu could be built for this campaign."""
    parts = ["no tone model (no spectra, no calibration runs to extend)"
             if getattr(prob, "tone", None) is None else "",
             "no gate settings" if getattr(prob, "gate", None) is None else ""]
    return ("no menu item can be predicted for this campaign: "
            + ("; ".join(filter(None, parts)) or "no recordings to extend"))


def describe_recording(what: str, s: dict) -> str:
    """The recording in words, e.g. ``"spectra at A = 0.85, 0.95 with and without DPD"``."""
    if what in ("amplitude_run", "phase_run"):
        n = int(s.get("runs", 1))
        if n > 1:
            return f"{n} more {what.split('_')[0]} calibration runs now"
        return {"amplitude_run": "one more amplitude calibration run now",
                "phase_run": "a phase calibration run"}[what]
    if what == "spectra":
        # repeats are rows at the same amplitude: named once, with their count
        amps, counts = np.unique(np.asarray(s["amplitudes"], dtype=float), return_counts=True)
        each = f" ({counts[0]} traces each)" if counts.max() > 1 and counts.min() == counts.max() \
            else ""
        listed = ", ".join(f"{a:g}" + (f" x{c}" if c > 1 and not each else "")
                           for a, c in zip(amps, counts))
        return f"spectra at A = {listed}{each} with and without DPD"
    if what == "detector_linearity":
        scans = int(s.get("scans", 1))
        return (f"a detector linearity check (the photodiode read at {s['points']} drives "
                f"without and with a {s.get('attenuation_db', 10.0):g} dB attenuator"
                + (f", {scans} times" if scans > 1 else "") + ")")
    if what == "spam":
        scans = int(s.get("scans", 1))
        states = ", ".join(f"|{x}>" for x in s.get("states", ("00", "11")))
        return (f"a SPAM characterisation ({states} prepared, detected with no gate; "
                f"{s['shots']} shots each" + (f", {scans} times" if scans > 1 else "") + ")")
    if what == "pulse_response":
        scans = int(s.get("scans", 1))
        return (f"an AOM pulse response (a step to A = {s['A']:g} traced by a fast "
                "photodiode" + (f", {scans} traces" if scans > 1 else "") + ")")
    if what == "ramsey":
        scans = int(s.get("scans", 1))
        return (f"a Ramsey and spin-echo scan ({s['points']} waits to "
                f"{s['max_wait_us'] / 1e3:g} ms, {s['shots']} shots each"
                + (f", {scans} times" if scans > 1 else "") + ")")
    if what == "thermometry":
        scans = int(s.get("scans", 1))
        waits = s.get("waits_us") or ()
        span = f"{len(waits)} waits up to {max(waits) / 1e3:g} ms, " if waits else ""
        return (f"a sideband thermometry ({span}red and blue sidebands; {s['shots']} shots "
                "each" + (f", {scans} times" if scans > 1 else "") + ")")
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
