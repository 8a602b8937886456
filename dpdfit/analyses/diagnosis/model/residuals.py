"""The diagnosis's problem: every observable of a campaign and its residuals.

:class:`Problem` holds the recordings standardised by
:mod:`dpdfit.analyses.diagnosis.observables.campaign`, the forward models
(:class:`~dpdfit.analyses.diagnosis.model.tones.tone_model.ToneModel`,
:class:`~dpdfit.analyses.diagnosis.model.gates.gate_model.GateModel`) and the baseline's
nuisances with their priors, and gives the standardised residuals of any
parameter set (:meth:`Problem.blocks`, :meth:`Problem.residuals`: the tone features'
:class:`~dpdfit.analyses.diagnosis.model.tones.tone_residuals.ToneResiduals`, the runs
after the recordings' :mod:`~dpdfit.analyses.diagnosis.model.runs_after` and
:mod:`~dpdfit.analyses.diagnosis.model.phase_runs_block`, the gates'
:class:`~dpdfit.analyses.diagnosis.model.gates.gate_residuals.GateResiduals` and the
priors) and the series the deviation search reads (:meth:`Problem.series`).

Before any effect is considered it learns what the lab does not state (the
null model, :mod:`~dpdfit.analyses.diagnosis.model.null_model`): the tone-side noise,
the sign convention of the recorded phase response (chosen by the gates) and the
gate-rate calibration's relative scatter.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from dpdfit.analyses.diagnosis.effects import EFFECTS, default_effects, effect_of_key
from dpdfit.analyses.diagnosis.model.gates.gate_model import (DETECTION_PRIOR_SIGMA,
                                                              GateModel)
from dpdfit.analyses.diagnosis.model.gates.gate_residuals import GateResiduals
from dpdfit.analyses.diagnosis.model.gates.rate_scatter import learn_rate_scatter
from dpdfit.analyses.diagnosis.model.linearity_block import linearity_block
from dpdfit.analyses.diagnosis.model.null_model import NullModel, choose_phase_sign
from dpdfit.analyses.diagnosis.model.phase_runs_block import phase_runs_block
from dpdfit.analyses.diagnosis.model.pulse_block import pulse_block
from dpdfit.analyses.diagnosis.model.ramsey_block import coherence_report, ramsey_block
from dpdfit.analyses.diagnosis.model.recorded_motion import RECORDED_MOTION
from dpdfit.analyses.diagnosis.model.runs_after import runs_after_block
from dpdfit.analyses.diagnosis.model.spam_block import spam_block
from dpdfit.analyses.diagnosis.model.thermometry_block import recorded_motion, thermometry_block
from dpdfit.analyses.diagnosis.model.tones.tone_model import ToneModel
from dpdfit.analyses.diagnosis.model.tones.tone_noise import (learn_tone_noise, repeats_of,
                                                              trace_jitter_multiple)
from dpdfit.analyses.diagnosis.model.tones.tone_residuals import ToneResiduals
from dpdfit.analyses.diagnosis.observables.campaign import Campaign

__all__ = ["Problem", "NUISANCES", "PM_PRIOR_RAD", "check_forms_left_out"]

#: without a phase file the lab does not know its AOM's AM-to-PM: the baseline has it as a
#: nuisance ``pm_x`` (a phase ``pm_x |x|^2`` of the RF drive, rad at full drive) with a
#: N(0, PM_PRIOR_RAD) prior.  0.02 rad: IM3 from such a PM stays below about -46 dB, where the fidelity
#: estimate changes by < 1e-4 (Table S1, exact formula); only a larger PM is missing physics
PM_PRIOR_RAD = 0.02

#: existing parameters of the model, refitted first: name -> (unit, meaning)
NUISANCES = {"cal_amp*": ("sigma", "error modes of the amplitude calibration "
                                     "(forward model only; prior N(0, 1))"),
             "cal_phase*": ("sigma", "error modes of the phase calibration"),
             "pm_x": ("rad", "the AOM's own AM-to-PM without a phase file (prior N(0, 0.02))"),
             "eps_ts*": ("dB", "each time scan's gate-rate error (prior: rate calibration)"),
             "gate_power_offset": ("dB", "absolute scale of the heterodyne tone powers")}


def check_forms_left_out(forms_left_out: dict | None) -> dict:
    """``{effect: frozenset(form names)}`` from a mapping of effect names to form names
    (KeyError naming the known effects or forms for an unknown one)."""
    out = {}
    for name, forms in (forms_left_out or {}).items():
        e = EFFECTS.get(name)
        if e is None:
            raise KeyError(f"unknown effect {name!r}; known: {', '.join(EFFECTS)}")
        forms = (forms,) if isinstance(forms, str) else tuple(forms)
        known = {f.name for f in e.forms_for()}
        for f in forms:
            if f not in known:
                raise KeyError(f"{name} has no form {f!r} (forms: {', '.join(sorted(known))})")
        out[name] = frozenset(forms)
    return out


class Problem:
    """All observables of a campaign and the residual function of a parameter set.

    Attributes
    ----------
    prior, center, bounds : dict
        The nuisances: name -> prior sigma (inf: flat), centre, optional bounds.
    tone_nuisances : set
        The nuisances of the tone side (the rest belong to the gates).
    tone, gate : ToneModel, GateModel or None
        The forward models in use (the gate model None without gate recordings).
    phase_sign_chi2, rate_scatter : dict or None
        What the null model learnt (:meth:`null_model`).
    """

    def __init__(self, camp: Campaign, with_gates: bool = True, effects=None,
                 forms_left_out: dict | None = None):
        #: the effects this problem may be asked to fit (their gate knobs get responses)
        self.effects = tuple(default_effects() if effects is None else effects)
        #: forms of the catalog this problem leaves out, ``{effect: frozenset(forms)}``
        #: (the harness's leave-one-form-out mode: a lab's physics in a form the catalog
        #: does not have)
        self.forms_left_out = check_forms_left_out(forms_left_out)
        self.tone = ToneModel(camp)
        # the tone-side noise (floor, repeatability, trace power jitter) learnt from the
        # recordings before any effect is considered (the null model)
        P, sd, self.tone_noise = learn_tone_noise(camp, self.tone.features({}))
        camp = dataclasses.replace(camp, P_dB=P, sd_dB=sd)
        self.camp = camp
        # a trace pooled from repeated recordings carries a share of one trace's jitter
        self.tone_residuals = ToneResiduals(camp.P_dB, camp.A_tones, camp.sd_dB,
                                            self.tone_noise.s_trace_db,
                                            trace_jitter_multiple(repeats_of(camp)))
        self.prior = {k: 1.0 for k in self.tone.mode_names}
        self.center = {k: 0.0 for k in self.tone.mode_names}
        self.bounds = {}
        if camp.phase is None:
            # the AOM's own AM-to-PM (a phase ~ |x|^2 of the drive) is unknown to the lab
            self.prior["pm_x"], self.center["pm_x"] = PM_PRIOR_RAD, 0.0
        self.tone_nuisances = set(self.prior)
        #: the calibration runs taken after the recordings (a data block of every
        #: hypothesis), or None
        self.runs_after = camp.runs_after
        self.gate, self.gate_residuals = None, None
        self.phase_sign_chi2, self.rate_scatter = None, None
        if with_gates and camp.gates is not None:
            self._init_gates(camp)

    @property
    def ts(self):
        """The time scans' points after the start (None without time scans or gates)."""
        return None if self.gate_residuals is None else self.gate_residuals.ts

    def forms_of(self, name: str) -> tuple:
        """Effect ``name``'s forms this campaign supports, less those left out
        (:attr:`forms_left_out`); a form started from a left-out one starts from that
        one's own start instead."""
        e = EFFECTS[name]
        out = e.forms_for(self)
        gone = self.forms_left_out.get(name, frozenset())
        if not gone:
            return out
        parent = {f.name: f.starts_from for f in out}
        kept = []
        for f in out:
            if f.name in gone:
                continue
            start = f.starts_from
            while start in gone:
                start = parent.get(start)
            kept.append(f if start == f.starts_from
                        else dataclasses.replace(f, starts_from=start))
        return tuple(kept)

    def _init_gates(self, camp: Campaign) -> None:
        """The gate model, the gate nuisances and what the null model learns from the gates."""
        em = camp.error_model
        # per-scan laser jitter: the lab's own figure, else the one learnt on the spectra
        jit = (float(em["power_jitter_db"]) if camp.has_error_model
               else self.tone_residuals.sig_jit)
        self.gate = GateModel(camp, self.tone, jit, effects=self.effects, responses=False)
        self.gate_residuals = GateResiduals(self.gate.gates, camp.time_scans)
        self.prior["prep_split"], self.center["prep_split"] = np.inf, 0.5
        self.bounds["prep_split"] = (0.0, 1.0)
        for k in ("e01", "e10"):
            self.prior[k], self.center[k] = DETECTION_PRIOR_SIGMA, self.gate.p_det
            self.bounds[k] = (0.0, self.gate.p_det + 50 * DETECTION_PRIOR_SIGMA)
        for k in range(self.gate.n_time_scans):
            self.prior[f"eps_ts{k}"] = self.gate.rate_error_db(self.gate.ts_keys[k])
            self.center[f"eps_ts{k}"] = 0.0
        if camp.thermometry is not None:
            self._init_recorded_motion()
        if camp.phase is not None:
            self.phase_sign_chi2 = choose_phase_sign(self)
        self.gate.compute_responses()
        for k in range(self.gate.n_time_scans):
            self.prior[f"eps_ts{k}"] = self.gate.rate_error_db(self.gate.ts_keys[k])
        self.rate_scatter = learn_rate_scatter(self)

    def _init_recorded_motion(self) -> None:
        """With thermometry: the knobs the recorded motional state moves
        (:mod:`~dpdfit.analyses.diagnosis.model.recorded_motion`), so that the state the
        recording measures on its own can be reported whatever effects are considered."""
        for knob in RECORDED_MOTION.knobs():
            self.gate.knobs.setdefault(knob.key, knob)

    def null_model(self, base=None) -> NullModel:
        """What the baseline learnt from the campaign before any effect (``base``: the
        baseline's fit, whose nuisances are reported as ``fitted``)."""
        return NullModel(
            tone_noise=self.tone_noise, calibration_noise=dict(self.camp.calibration_noise),
            phase_sign=self.tone.phase_sign if self.camp.phase is not None else None,
            phase_sign_chi2=self.phase_sign_chi2, rate_scatter=self.rate_scatter,
            per_scan_power_jitter_db=None if self.gate is None else self.gate.sig_jit,
            preparation_error_total=None if self.gate is None else self.gate.p_total,
            fitted=None if base is None else {k: v for k, v in base.nuisances.items()
                                              if not k.startswith("cal_")},
            coherence=(coherence_report(self, base)
                       if self.gate is not None and self.camp.ramsey is not None else None),
            detector_linearity_noise=(None if self.camp.detector_linearity is None
                                      else self.camp.detector_linearity.noise),
            recorded_motion=recorded_motion(self, base))

    # ------------------------------------------------------------ models in use
    def use_tone(self, tone: ToneModel) -> None:
        """Evaluate the tone side with ``tone`` (e.g. the other phase-sign convention)."""
        self.tone = tone
        self.tone_residuals.reset()

    def set_rate_scatter(self, rel: float) -> None:
        """Hold the gate-rate calibration's relative scatter at ``rel`` (and the time
        scans' rate-error priors with it)."""
        self.gate.set_rate_scatter(rel)
        for k in range(self.gate.n_time_scans):
            self.prior[f"eps_ts{k}"] = self.gate.rate_error_db(self.gate.ts_keys[k])

    # -------------------------------------------------------------- residuals
    def is_tone_key(self, k: str) -> bool:
        """Whether the parameter ``k`` belongs to the tone side (a tone-side effect's or a
        tone nuisance; the rest belong to the gates)."""
        e = effect_of_key(k)
        return k in self.tone_nuisances if e is None else e.side == "tones"

    def gate_whitened(self, p: dict, logdet: bool = False):
        """Whitened gate residuals at ``p``
        (:meth:`~dpdfit.analyses.diagnosis.model.gates.gate_residuals.GateResiduals.whitened`;
        with ``logdet``, also the log-determinant of their covariance)."""
        return self.gate_residuals.whitened(self.gate, p, logdet)

    def residuals(self, p: dict, with_prior: bool = True) -> np.ndarray:
        """All standardised residuals at the parameter set ``p`` as one vector (the
        :meth:`blocks` concatenated; ``with_prior``: with the priors' residuals)."""
        return np.concatenate([np.ravel(z) for _, z in self.blocks(p, with_prior)])

    def blocks(self, p: dict, with_prior: bool = True, whiten: bool = True,
               with_tones: bool = True):
        """(label, z) blocks; labels are dicts of observable/sideband/dpd/x.

        The tone features, the runs after the recordings (amplitude:
        :mod:`~dpdfit.analyses.diagnosis.model.runs_after`; phase:
        :mod:`~dpdfit.analyses.diagnosis.model.phase_runs_block`), the gates (whitened per
        setting with ``whiten``, the fits; each observable standardised on its own
        without it, for the deviation search and plots:
        :meth:`~dpdfit.analyses.diagnosis.model.gates.gate_residuals.GateResiduals.gate_blocks`),
        the SPAM characterisation with the gates
        (:func:`~dpdfit.analyses.diagnosis.model.spam_block.spam_block`), the AOM pulse
        response with the tones
        (:func:`~dpdfit.analyses.diagnosis.model.pulse_block.pulse_block`), the Ramsey and
        spin-echo characterisation
        (:func:`~dpdfit.analyses.diagnosis.model.ramsey_block.ramsey_block`), the detector
        linearity characterisation with the tones
        (:func:`~dpdfit.analyses.diagnosis.model.linearity_block.linearity_block`), the
        sideband thermometry with the gates
        (:func:`~dpdfit.analyses.diagnosis.model.thermometry_block.thermometry_block`) and,
        ``with_prior``, the priors.  Each side sees its own parameters only.
        """
        tone_p = {k: v for k, v in p.items() if self.is_tone_key(k)}
        gate_p = {k: v for k, v in p.items() if k not in tone_p}
        out = []
        if with_tones:
            out += self.tone_residuals.feature_blocks(self.tone, tone_p)
            if self.runs_after is not None:
                out.append(runs_after_block(self, p))
            if self.camp.pulse_response is not None:
                out.append(pulse_block(self, tone_p))
            if self.camp.detector_linearity is not None:
                out.append(linearity_block(self, tone_p))
            if self.camp.phase_runs_after is not None:
                out.append(phase_runs_block(self, tone_p))
        if self.gate is not None:
            out += self.gate_residuals.gate_blocks(self.gate, gate_p, whiten)
            if self.camp.spam is not None:
                out.append(spam_block(self, gate_p))
            if self.camp.ramsey is not None:
                out.append(ramsey_block(self, gate_p))
            if self.camp.thermometry is not None:
                out.append(thermometry_block(self, gate_p))
        if with_prior:
            z = np.array([(p.get(k, self.center[k]) - self.center[k]) / s
                          for k, s in self.prior.items() if np.isfinite(s)])
            out.append(({"kind": "prior", "observable": "prior"}, z))
        return out

    def series(self, p: dict):
        """Series for the deviation search: list of (observable, sideband, dpd, x_name, x, z)."""
        out = []
        A = self.camp.A_tones
        for lab, z in self.blocks(p, with_prior=False, whiten=False):
            kind, name = lab["kind"], lab["observable"]
            if kind == "tones":
                for d in (0, 1):
                    for j in range(z.shape[2]):
                        sb = (("red", "blue")[j] if z.shape[2] == 2 else "both")
                        zz = z[:, d, j]
                        ok = np.isfinite(zz)
                        if ok.sum() >= 2:
                            out.append((name, sb, d, "A", A[ok], zz[ok]))
            elif kind == "gates":
                g = self.gate.gates
                for d in (0, 1):
                    sel = (g.dpd == d).to_numpy()
                    if sel.sum() >= 2:
                        out.append((name, "both", d, "xi0_khz", g.xi0_hz.to_numpy()[sel] / 1e3,
                                    z[sel]))
            elif kind == "time_scan":
                for d in (0, 1):
                    sel = (self.ts.dpd == d).to_numpy()
                    if sel.sum() >= 2:
                        out.append((name, "both", d, "t_us", self.ts.t_s.to_numpy()[sel] * 1e6,
                                    z[sel]))
        cal = self.camp.amp_residuals
        out.append(("calibration_amplitude", "none", -1, "A", cal.A.to_numpy(),
                    cal.z.to_numpy()))
        if self.camp.phase_residuals is not None:
            ph = self.camp.phase_residuals
            out.append(("calibration_phase", "none", -1, "A", ph.A.to_numpy(), ph.z.to_numpy()))
        return out
