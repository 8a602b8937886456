"""The diagnosis's problem: every observable of a campaign and its residuals.

:class:`Problem` holds the recordings standardised by
:mod:`dpdfit.analyses.diagnosis.observables.campaign`, the forward models
(:class:`~dpdfit.analyses.diagnosis.model.tones.tone_model.ToneModel`,
:class:`~dpdfit.analyses.diagnosis.model.gates.gate_model.GateModel`) and the baseline's
nuisances with their priors, and gives the standardised residuals of any
parameter set (:meth:`Problem.blocks`, :meth:`Problem.residuals`) and the
series the interval scan reads (:meth:`Problem.series`).

Before any effect is considered it learns what the lab does not state (the
null model): the tone-side noise
(:mod:`dpdfit.analyses.diagnosis.model.tones.tone_noise`), the sign convention of the
recorded phase response (chosen by the gates) and the gate-rate calibration's
relative scatter (:mod:`dpdfit.analyses.diagnosis.model.gates.rate_scatter`).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from dpdfit.analyses.diagnosis.effects import EFFECTS, default_effects, effect_of_key
from dpdfit.analyses.diagnosis.model.gates.gate_model import (DETECTION_PRIOR_SIGMA,
                                                              GateModel)
from dpdfit.analyses.diagnosis.model.tones.tone_noise import (learn_tone_noise, repeats_of,
                                                              trace_jitter_multiple)
from dpdfit.analyses.diagnosis.observables.campaign import Campaign
from dpdfit.analyses.diagnosis.observables.tone_features import tone_features
from dpdfit.analyses.diagnosis.model.gates.rate_scatter import learn_rate_scatter
from dpdfit.analyses.diagnosis.model.tones.tone_model import ToneModel

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
        self._cache_key, self._cache_val = None, None
        # the tone-side noise (floor, repeatability, trace power jitter) learnt from the
        # recordings before any effect is considered (dpdfit.analyses.diagnosis.model.tones.tone_noise)
        P, sd, self.tone_noise = learn_tone_noise(camp, self.tone.features({}))
        camp = dataclasses.replace(camp, P_dB=P, sd_dB=sd)
        self.camp = camp
        self.meas = tone_features(camp.P_dB, camp.A_tones, camp.sd_dB)
        self.sig_jit = self.tone_noise.s_trace_db
        # a trace pooled from repeated recordings carries a share of one trace's jitter
        self.jit_multiple = trace_jitter_multiple(repeats_of(camp))
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
        self.gate, self.ts = None, None
        self.phase_sign_chi2, self.rate_scatter = None, None
        if with_gates and camp.gates is not None:
            self._init_gates(camp)

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
        jit = float(em["power_jitter_db"]) if camp.has_error_model else self.sig_jit
        self.gate = GateModel(camp, self.tone, jit, effects=self.effects, responses=False)
        g = self.gate.gates
        self.g_obs = tuple(q for q in ("F_pop", "imb", "C") if np.isfinite(g[q]).any())
        self.g_meas = {q: g[q].to_numpy() for q in self.g_obs}
        self.g_shot = {q: g[q + "_shot"].to_numpy() for q in self.g_obs}
        self.ts = None if camp.time_scans is None else _scan_points(camp.time_scans)
        self.prior["prep_split"], self.center["prep_split"] = np.inf, 0.5
        self.bounds["prep_split"] = (0.0, 1.0)
        for k in ("e01", "e10"):
            self.prior[k], self.center[k] = DETECTION_PRIOR_SIGMA, self.gate.p_det
            self.bounds[k] = (0.0, self.gate.p_det + 50 * DETECTION_PRIOR_SIGMA)
        for k in range(self.gate.n_time_scans):
            self.prior[f"eps_ts{k}"] = self.gate.rate_error_db(self.gate.ts_keys[k])
            self.center[f"eps_ts{k}"] = 0.0
        if camp.phase is not None:
            self._choose_phase_sign()
        self.gate.compute_responses()
        for k in range(self.gate.n_time_scans):
            self.prior[f"eps_ts{k}"] = self.gate.rate_error_db(self.gate.ts_keys[k])
        self.rate_scatter = learn_rate_scatter(self)

    def _gate_chi2(self) -> float:
        """Gate and time-scan chi2 of the baseline, the preparation split profiled on a grid."""
        best = np.inf
        for f in np.linspace(0.0, 1.0, 11):
            z = [zz for lab, zz in self.blocks({"prep_split": f}, with_prior=False,
                                                with_tones=False)]
            z = np.concatenate([np.ravel(x) for x in z])
            best = min(best, float(np.sum(z[np.isfinite(z)] ** 2)))
        return best

    def _choose_phase_sign(self):
        """The sign convention of the recorded phase response, chosen by the gates.

        The tone powers are the same for both signs (:meth:`ToneModel.with_phase_sign`);
        the gates are not.  Both baselines' means are evaluated (the other sign's two-ion
        branch only: the single-ion branches of the preparation errors weigh ~1e-3 and
        are kept; all of them when that sign is kept; the effect responses are then
        computed once for the chosen sign) and the one with the smaller gate chi2 is
        kept; both are reported.
        """
        plus = self._gate_chi2()
        alt_tone = self.tone.with_phase_sign(-1)
        keep = self.gate
        self.gate = keep.rebased(alt_tone, {}, two_ion_only=True)
        minus = self._gate_chi2()
        self.phase_sign_chi2 = {"+1": plus, "-1": minus}
        if minus < plus:
            self.use_tone(alt_tone)
            self.gate = keep.rebased(alt_tone, {})
        else:
            self.gate = keep

    def null_model(self, base=None) -> dict:
        """What the baseline learnt from the campaign before any effect."""
        out = {"tone_noise": self.tone_noise.to_dict(),
               "calibration_noise": dict(self.camp.calibration_noise),
               "phase_sign": self.tone.phase_sign if self.camp.phase is not None else None,
               "phase_sign_chi2": self.phase_sign_chi2,
               "rate_scatter": self.rate_scatter,
               "per_scan_power_jitter_db": None if self.gate is None else self.gate.sig_jit,
               "preparation_error_total": None if self.gate is None else self.gate.p_total}
        if base is not None:
            out["fitted"] = {k: v for k, v in base.nuisances.items()
                             if not k.startswith("cal_")}
        return out

    # ------------------------------------------------------------ models in use
    def use_tone(self, tone: ToneModel) -> None:
        """Evaluate the tone side with ``tone`` (e.g. the other phase-sign convention)."""
        self.tone, self._cache_key = tone, None

    def set_rate_scatter(self, rel: float) -> None:
        """Hold the gate-rate calibration's relative scatter at ``rel`` (and the time
        scans' rate-error priors with it)."""
        self.gate.set_rate_scatter(rel)
        for k in range(self.gate.n_time_scans):
            self.prior[f"eps_ts{k}"] = self.gate.rate_error_db(self.gate.ts_keys[k])

    # -------------------------------------------------------------- residuals
    def _is_tone_key(self, k: str) -> bool:
        e = effect_of_key(k)
        return k in self.tone_nuisances if e is None else e.side == "tones"

    def _tone_features(self, p: dict) -> dict:
        key = tuple(sorted((k, float(v)) for k, v in p.items() if self._is_tone_key(k)))
        if key != self._cache_key:
            self._cache_key, self._cache_val = key, self.tone.features(p)
        return self._cache_val

    def gate_whitened(self, p: dict, logdet: bool = False):
        """Whitened gate residuals at ``p`` (:func:`_whiten_settings`; with ``logdet``,
        also the log-determinant of their covariance)."""
        return self._whiten(self.gate.predict(p), logdet)

    def _whiten(self, pr: dict, logdet: bool = False):
        """Whitened gate residuals of the gate model's prediction ``pr``."""
        qs = self.g_obs
        r = np.stack([self.g_meas[q] - pr[q] for q in qs], axis=1)
        return _whiten_settings(r, np.stack([self.g_shot[q] for q in qs], axis=1),
                                np.stack([pr["dlin_" + q] for q in qs], axis=1),
                                np.stack([pr["dquad_" + q] for q in qs], axis=1),
                                pr["v_lin"], pr["v_quad"], logdet=logdet)

    def residuals(self, p: dict, with_prior: bool = True) -> np.ndarray:
        """All standardised residuals at the parameter set ``p`` as one vector (the
        :meth:`blocks` concatenated; ``with_prior``: with the priors' residuals)."""
        return np.concatenate([np.ravel(z) for _, z in self.blocks(p, with_prior)])

    def blocks(self, p: dict, with_prior: bool = True, whiten: bool = True,
               with_tones: bool = True):
        """(label, z) blocks; labels are dicts of observable/sideband/dpd/x.

        With ``whiten`` (the fits) the gate observables of one setting, which
        share its random power errors, are decorrelated (:func:`_whiten_settings`:
        ``F_pop`` standardised, ``imb`` given ``F_pop``, ``C`` given both), so
        their chi2 counts the shared error once; without it (interval scan,
        plots) each is standardised on its own.
        """
        out = self._tone_blocks(p) if with_tones else []
        if with_tones and self.runs_after is not None:
            out.append(({"kind": "runs", "observable": "calibration_after"},
                        self._runs_after_z(p)))
        if self.gate is not None:
            out += self._gate_blocks(p, whiten)
        if with_prior:
            z = np.array([(p.get(k, self.center[k]) - self.center[k]) / s
                          for k, s in self.prior.items() if np.isfinite(s)])
            out.append(({"kind": "prior", "observable": "prior"}, z))
        return out

    def _runs_after_z(self, p: dict) -> np.ndarray:
        """Standardised residuals of the runs taken after the recordings: the null (the
        runs before them) plus the drift the effects present predict."""
        ra = self.runs_after
        shift = np.zeros_like(ra.coords)
        for e in EFFECTS.values():
            v = e.values(p)
            if v is not None:
                s = e.run_drift(self, v, ra.days)
                if s is not None:
                    shift = shift + s
        return ra.residuals(shift).ravel()

    def _tone_blocks(self, p: dict) -> list:
        out = []
        model = self._tone_features(p)
        for name, (v, e) in self.meas.items():
            m = model[name]
            if name == "gate_power":
                # absolute scale of the tone powers: profiled (weighted mean), 1 parameter
                e = np.sqrt(e ** 2 + self.sig_jit ** 2 * self.jit_multiple)
                r = v - m
                ok = np.isfinite(r)
                m = m + (np.sum(r[ok] / e[ok] ** 2) / np.sum(1 / e[ok] ** 2) if ok.any() else 0)
            z = (v - m) / e
            out.append(({"kind": "tones", "observable": name}, z))
        return out

    def _gate_blocks(self, p: dict, whiten: bool) -> list:
        # cached on the gate side's parameters: a tone-side fit holds them, and then the
        # gate residuals are the same at every one of its evaluations
        g = self.gate
        key = (id(g), id(g.base), getattr(g, "rate_rel", None), g.resp is None, whiten,
               tuple(sorted((k, float(v)) for k, v in p.items() if not self._is_tone_key(k))))
        if getattr(self, "_gate_key", None) == key:
            return list(self._gate_val)
        out = self._gate_blocks_uncached(p, whiten)
        self._gate_key, self._gate_val = key, out
        return list(out)

    def _gate_blocks_uncached(self, p: dict, whiten: bool) -> list:
        out = []
        pr = self.gate.predict(p)
        qs = self.g_obs
        if whiten:
            z = self._whiten(pr)
        else:
            r = np.stack([self.g_meas[q] - pr[q] for q in qs], axis=1)
            z = r / np.sqrt(np.stack([self.g_shot[q] ** 2 + pr["var_" + q] for q in qs],
                                     axis=1))
        for j, q in enumerate(qs):
            out.append(({"kind": "gates", "observable": q}, z[:, j]))
        if self.ts is not None and "P00_t" in pr:
            N = self.ts["shots"].to_numpy(dtype=float)
            for q, col in (("P00_t", "n00"), ("P11_t", "n11")):
                pm = np.clip(pr[q], 0.5 / N, 1 - 0.5 / N)
                z = (self.ts[col].to_numpy() / N - pr[q]) / np.sqrt(pm * (1 - pm) / N)
                out.append(({"kind": "time_scan", "observable": q}, z))
        return out

    def series(self, p: dict):
        """Series for the interval scan: list of (observable, sideband, dpd, x_name, x, z)."""
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


def _scan_points(ts: pd.DataFrame) -> pd.DataFrame:
    """The time scans' points after the start (``t > 0``), grouped by setting."""
    parts = []
    for (A, d), t in ts.groupby(["A", "dpd"], sort=False):
        parts.append(t[t.t_s > 0])
    return pd.concat(parts, ignore_index=True)


def _whiten_settings(r, shot, g, h, v_lin, v_quad, logdet: bool = False):
    """Whitened residuals of each setting's gate observables (shape (n, 3)).

    ``r``: residuals, ``shot``: their shot-noise errors, ``g``, ``h``: the
    settings' responses to the shared random power error (linear and
    quadratic parts, :meth:`dpdfit.analyses.diagnosis.model.gates.gate_model.GateModel.predict`), with
    variances ``v_lin``, ``v_quad`` (arrays over settings).  The covariance of one
    setting is ``diag(shot^2) + v_lin g g^T + v_quad h h^T``; its Cholesky
    factor ``L`` gives ``z = L^-1 r`` (N(0, I) under the model), whose sum of
    squares is the Mahalanobis chi2.  Settings with a missing value keep the
    marginal standardisation.  Hand-written: a batched 3x3 Cholesky solve.
    """
    v_lin = np.broadcast_to(np.asarray(v_lin, float), r.shape[:1])
    v_quad = np.broadcast_to(np.asarray(v_quad, float), r.shape[:1])
    cov = (np.einsum("i,ij,ik->ijk", v_lin, g, g) + np.einsum("i,ij,ik->ijk", v_quad, h, h)
           + np.einsum("ij,jk->ijk", shot ** 2, np.eye(r.shape[1])))
    diag = np.einsum("ijj->ij", cov)
    z = r / np.sqrt(diag)
    ld = np.where(np.isfinite(r), np.log(diag), 0.0).sum(axis=1)
    ok = np.all(np.isfinite(r), axis=1) & np.all(np.isfinite(cov), axis=(1, 2))
    if ok.any():
        L = np.linalg.cholesky(cov[ok])
        z[ok] = np.linalg.solve(L, r[ok][..., None])[..., 0]
        ld[ok] = 2 * np.log(np.einsum("ijj->ij", L)).sum(axis=1)
    return (z, float(ld.sum())) if logdet else z
