"""Discrepancy diagnosis: locate, name, model and show the improvement (issue #7).

Steps (:func:`diagnose`):

1. **Baseline.**  The simulation built from the campaign's own calibration
   (:mod:`dpdfit.analyses.diagnosis.effects`) predicts every observable of
   :mod:`dpdfit.analyses.diagnosis.observables`.  Its existing parameters (nuisances) are refitted
   first, with Gaussian priors from the calibration: if that absorbs the
   mismatch there is nothing to explain.
2. **Locate.**  Standardised residuals ``z = (recorded - simulated)/sigma`` of
   each series (observable x sideband x flag, ordered by A, xi0 or t) are
   scanned for intervals of significant deviation (:func:`dpdfit.analyses.diagnosis.scan.scan_intervals`),
   Bonferroni-corrected over all intervals and all series.
3. **Name.**  Each catalog effect, and pairs of the three best, is fitted
   jointly to all observables (nuisances refitted with it) by
   ``scipy.optimize.least_squares``; effects are ranked by
   ``delta_bic = BIC(effect) - BIC(baseline)`` (negative favours the effect)
   and a likelihood-ratio test (``p_value``: Wilks, chi2 with as many degrees
   of freedom as the effect has parameters).
4. **Verdict.**  ``"none"`` when there is no evidence of a mismatch: the
   baseline's global chi2 p-value, every located interval and the targeted
   test (the best single effect's LRT p-value times the number of effects
   tried, with ``delta_bic < -BIC_DECISIVE``) are all above ``ALPHA``
   (``mismatch_evidence`` lists which fired); else the best effect if it is
   decisive (``delta_bic < -BIC_DECISIVE``, LRT ``p < ALPHA``) *and* leaves an
   acceptable fit (chi2 p-value >= ``ALPHA_FIT``); a pair ``"a+b"`` when only
   a pair does that; else ``"unexplained"``.

Parameter errors are the Gauss-Newton ones, ``(J^T J)^-1`` of the standardised
residuals at the optimum (1 sigma), with the calibration's error modes profiled
out (:class:`_Profile`), so they include the calibration uncertainty;
``params_err`` is NaN when a parameter sits at its bound.
"""

from __future__ import annotations

import dataclasses
import itertools
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.optimize import least_squares
from scipy.stats import chi2 as chi2_dist
from threadpoolctl import threadpool_limits

from dpdfit.core.parallel import pmap

from dpdfit.analyses.diagnosis.effects import EFFECTS, NUISANCES, STALE_AOM, TONE_PARAMS, VARIANTS, ToneModel
from dpdfit.analyses.diagnosis.gate_model import DETECTION_PRIOR_SIGMA, GATE_NUISANCES, GateModel
from dpdfit.models.fidelity import estimate
from dpdfit.analyses.diagnosis.null_model import learn_tone_noise
from dpdfit.analyses.diagnosis.observables import HARMONICS, Campaign, load_campaign, tone_features
from dpdfit.models.waveforms import cardioid, synthesize
from dpdfit.analyses.diagnosis.scan import scan_intervals

__all__ = ["diagnose", "Diagnosis", "Problem", "mismatch_evidence", "ALPHA", "BIC_DECISIVE"]

#: global false-alarm level of a mismatch (3 sigma)
ALPHA = 0.0027
#: a fit is acceptable if its chi2 p-value is at least this
ALPHA_FIT = 1e-4
#: |delta BIC| that counts as decisive (Kass & Raftery: > 10 "very strong")
BIC_DECISIVE = 10.0
#: a pair whose second effect adds less than this fraction of the first's chi2 improvement
#: names the first (dominant) effect
DOMINANT_FRACTION = 0.01
#: stale_calibration's "drift" is the table calibration's fractional y(A) difference at this A
DRIFT_AT_A = 0.5
#: cap on residual evaluations per least-squares start
MAX_NFEV = 100
#: calibration modes profiled out linearly (:class:`_Profile`): Jacobian step (sigma),
#: re-linearisations at the optimum, and the change of the modes (sigma) that ends them
PROFILE_STEP = 0.1
PROFILE_RELIN = 3
PROFILE_TOL = 0.05
#: finite-difference step of the fits' Jacobian, in units of each parameter's scale
FD_STEP = 1e-3
#: evaluations of the short runs that choose among several starts
SCREEN_NFEV = 15
#: a baseline nuisance further than this (prior sigmas) from its centre also gets a
#: start from the centre in the effect fits
FAR_NUISANCE = 5.0
#: the gate-rate calibration's relative scatter (a nuisance).  When the lab states each
#: setting's rate error (``xi0_err_khz``): log-normal prior centred on the stated error,
#: RATE_SCATTER_PRIOR_FACTOR wide (1 sigma), on a grid spanning +/- 3 sigma; else
#: log-uniform on [RATE_SCATTER_MIN, RATE_SCATTER_MAX_FACTOR x the default error]
RATE_SCATTER_MIN = 1e-4
RATE_SCATTER_MAX_FACTOR = 2.0
RATE_SCATTER_POINTS = 9
RATE_SCATTER_PRIOR_FACTOR = 2.0
#: outward continuation sweeps of the rate-scatter profile, at most (another only when the
#: best point moved)
PROFILE_SWEEPS = 3
#: gate-side effects whose parameters are free while the rate scatter is estimated
GATE_SIDE_FREE = ("gate_rate_miscalibration", "dephasing", "motional_heating", "spam_offset")
#: coarse grid seeding the AOM-memory fit: tau (ns) x f_off (MHz)
MEMORY_GRID_TAU = (20.0, 45.0, 75.0, 110.0, 160.0)
MEMORY_GRID_FOFF = (-4.5, -3.0, -2.0, -1.2, -0.6, 0.6, 1.2, 2.0, 3.0, 4.5)
#: internal name of stale_calibration's AOM-drift variant (reported as stale_calibration)
STALE_AOM_KEY = "stale_calibration@aom"
#: without a phase file the lab does not know its AOM's AM-to-PM: the baseline has it as a
#: nuisance (the am_pm_omitted parameter dphi, rad at full drive) with a N(0, PM_PRIOR_RAD)
#: prior.  0.02 rad: IM3 from such a PM stays below about -46 dB, where the fidelity
#: estimate changes by < 1e-4 (Table S2, exact formula); only a larger PM is missing physics
PM_PRIOR_RAD = 0.02
#: an effect matters if it changes some fidelity at a recorded setting by at least this
#: (the spectral estimate F_est for tone-side effects, (F_pop + C)/2 for gate-side ones);
#: only effects that matter count for the targeted test (mismatch_evidence)
MATERIAL_FIDELITY = 1e-4
#: seed grids of effects with multimodal chi2 surfaces: (param a, param b) -> (grid a, grid b);
#: the fit starts from the best grid point of each sign of b
SEED_GRIDS = {"aom_memory": (("tau", "f_off"), (MEMORY_GRID_TAU, MEMORY_GRID_FOFF)),
              "aom_memory@thermal": (("th_tau", "th_p"), ((0.3, 1.0, 3.0, 10.0),
                                                          (-0.1, -0.02, 0.02, 0.1)))}
#: a single effect that leaves no acceptable fit is still named when it is decisive and
#: explains at least this fraction of the baseline's excess chi2 (chi2 - dof): its form is
#: then not exactly the catalog's; the report says how much is explained
EXPLAINED_FRACTION = 0.95
#: effects considered by default
DEFAULT_EFFECTS = ("am_pm_omitted", "aom_memory", "stale_calibration", "higher_order_im",
                   "detector_nonlinearity", "motional_heating", "dephasing", "spam_offset",
                   "gate_rate_miscalibration")


class Problem:
    """All observables of a campaign and the residual function of a parameter set."""

    def __init__(self, camp: Campaign, with_gates: bool = True):
        self.tone = ToneModel(camp)
        # the tone-side noise (floor, repeatability, trace power jitter) learnt from the
        # recordings before any effect is considered (dpdfit.analyses.diagnosis.null_model)
        P, sd, self.tone_noise = learn_tone_noise(camp, self.tone.features({}))
        camp = dataclasses.replace(camp, P_dB=P, sd_dB=sd)
        self.camp = camp
        self.meas = tone_features(camp.P_dB, camp.A_tones, camp.sd_dB)
        self.sig_jit = self.tone_noise.s_trace_db
        # nuisances: name -> prior sigma (inf: flat), centre, optional bounds
        self.prior = {k: 1.0 for k in self.tone.mode_names}
        self.center = {k: 0.0 for k in self.tone.mode_names}
        self.bounds = {}
        if camp.phase is None:
            # the AOM's own AM-to-PM (a phase ~ |x|^2 of the drive) is unknown to the lab
            self.prior["dphi_x"], self.center["dphi_x"] = PM_PRIOR_RAD, 0.0
        #: nuisances of the tone side (the rest belong to the gates)
        self.tone_nuisances = set(self.prior)
        if with_gates and camp.gates is not None:
            em = camp.error_model
            # per-scan laser jitter: the lab's own figure, else the one learnt on the spectra
            jit = float(em["power_jitter_db"]) if camp.has_error_model else self.sig_jit
            self.gate = GateModel(camp, self.tone, jit, responses=False)
            self.phase_sign_chi2 = None
            g = self.gate.gates
            self.g_obs = tuple(q for q in ("F_pop", "imb", "C") if np.isfinite(g[q]).any())
            self.g_meas = {q: g[q].to_numpy() for q in self.g_obs}
            self.g_shot = {q: g[q + "_shot"].to_numpy() for q in self.g_obs}
            ts = camp.time_scans
            if ts is not None:
                parts = []
                for (A, d), t in ts.groupby(["A", "dpd"], sort=False):
                    parts.append(t[t.t_s > 0])
                self.ts = pd.concat(parts, ignore_index=True)
            else:
                self.ts = None
            self.prior["prep_split"], self.center["prep_split"] = np.inf, 0.5
            self.bounds["prep_split"] = (0.0, 1.0)
            for k in ("e01", "e10"):
                self.prior[k], self.center[k] = DETECTION_PRIOR_SIGMA, self.gate.p_det
                self.bounds[k] = (0.0, self.gate.p_det + 50 * DETECTION_PRIOR_SIGMA)
            for k in range(self.gate.n_time_scans):
                self.prior[f"eps_ts{k}"] = self.gate.rate_error_db()
                self.center[f"eps_ts{k}"] = 0.0
            if camp.phase is not None:
                self._choose_phase_sign()
            self.gate.compute_responses()
            for k in range(self.gate.n_time_scans):
                self.prior[f"eps_ts{k}"] = self.gate.rate_error_db()
            self.rate_scatter = self._learn_rate_scatter()
        else:
            self.gate = None
        self._cache_key, self._cache_val = None, None

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
        the gates are not.  Both baselines' means are evaluated (engine base runs for
        each sign, before the effect responses, which are then computed once for the
        chosen sign) and the one with the smaller gate chi2 is kept; both are reported.
        """
        plus = self._gate_chi2()
        alt_tone = self.tone.with_phase_sign(-1)
        keep = self.gate
        self.gate = keep.rebased(alt_tone, {})
        minus = self._gate_chi2()
        self.phase_sign_chi2 = {"+1": plus, "-1": minus}
        if minus < plus:
            self.tone = alt_tone
            self._cache_key = None
        else:
            self.gate = keep

    def null_model(self, base=None) -> dict:
        """What the baseline learnt from the campaign before any effect (issue #14)."""
        out = {"tone_noise": self.tone_noise.to_dict(),
               "calibration_noise": dict(self.camp.calibration_noise),
               "phase_sign": self.tone.phase_sign if self.camp.phase is not None else None,
               "phase_sign_chi2": getattr(self, "phase_sign_chi2", None),
               "rate_scatter": getattr(self, "rate_scatter", None),
               "per_scan_power_jitter_db": None if self.gate is None else self.gate.sig_jit,
               "preparation_error_total": None if self.gate is None else self.gate.p_total}
        if base is not None:
            out["fitted"] = {k: v for k, v in base.nuisances.items()
                             if not k.startswith("cal_")}
        return out

    def _set_rate_scatter(self, rel: float) -> None:
        self.gate.set_rate_scatter(rel)
        for k in range(self.gate.n_time_scans):
            self.prior[f"eps_ts{k}"] = self.gate.rate_error_db()

    def _gate_nll(self, rel: float, start: dict | None = None):
        """-2 ln L of the gate recordings at relative rate scatter ``rel``.

        The gate nuisances *and every gate-side effect's parameters* (a common power
        offset, extra dephasing, heating and preparation error) are fitted with it,
        as in restricted maximum likelihood: the scatter is then what no smooth
        gate-side effect explains, so it cannot absorb one.  ``start``: the fit's
        starting point (a previous result's parameters), else the nuisances' centres
        with every effect absent.
        """
        self._set_rate_scatter(rel)
        # the widest form of each (catalog form plus its variants' extra parameters)
        eff = list({par.name: par for e in GATE_SIDE_FREE
                    for form in [EFFECTS[e]] + [v for k, v in VARIANTS.items()
                                                if k.split("@")[0] == e]
                    for par in form.params}.values())
        ts = [f"eps_ts{k}" for k in range(self.gate.n_time_scans)]
        names = ["prep_split", "e01", "e10"] + [par.name for par in eff] + ts
        lo = [0.0, 0.0, 0.0] + [par.lo for par in eff] + [-50 * self.prior[n] for n in ts]
        hi = ([1.0, self.bounds["e01"][1], self.bounds["e10"][1]] + [par.hi for par in eff]
              + [50 * self.prior[n] for n in ts])
        x0 = ([0.5, self.gate.p_det, self.gate.p_det]
              + [float(np.clip(0.0, par.lo, par.hi)) for par in eff] + [0.0] * len(ts))
        if start is not None:
            x0 = [start[n] for n in names]
        scale = [0.1, 1e-4, 1e-4] + [par.scale for par in eff] + [self.prior[n] for n in ts]
        priors = [(n, self.prior[n]) for n in names if n in self.prior
                  and np.isfinite(self.prior[n])]
        pad = 1e-9 * (np.array(hi) - np.array(lo))

        def fun(x):
            p = dict(zip(names, x))
            z = [np.ravel(zz) for _, zz in self.blocks(p, with_prior=False, with_tones=False)]
            z = np.concatenate(z + [[(p[n] - self.center[n]) / s for n, s in priors]])
            return np.where(np.isfinite(z), z, 0.0)

        r = least_squares(fun, np.clip(x0, np.array(lo) + pad, np.array(hi) - pad),
                          bounds=(lo, hi), x_scale=scale, max_nfev=200)
        p = dict(zip(names, r.x))
        _, ld = self._gate_whitened(p, logdet=True)
        ld += sum(2 * np.log(s) for n, s in priors if n.startswith("eps_ts"))
        return float(2 * r.cost + ld), p

    def _profile_rate_scatter(self, grid: np.ndarray) -> np.ndarray:
        """-2 ln L profiled over the gate nuisances and effects at each scatter of ``grid``.

        A profile is a minimum: each point is fitted from the nuisances' centres
        (cold) and then again from its neighbour's optimum, sweeping outwards from
        the best point (continuation), keeping the lower.  The cold fits alone stop
        in local minima of the 10-odd-parameter fit at some grid points (seen as
        jumps of 5-10 units between neighbours on another simulator's campaigns),
        and the posterior then piles up on whichever point happened to converge.
        """
        fits = [self._gate_nll(v) for v in grid]
        i0 = None
        for _ in range(PROFILE_SWEEPS):
            i1 = int(np.argmin([f[0] for f in fits]))
            if i1 == i0:
                break               # the same sweep again would repeat the same starts
            i0 = i1
            for order, step in ((range(i0 + 1, grid.size), -1), (range(i0 - 1, -1, -1), 1)):
                for i in order:
                    f = self._gate_nll(grid[i], start=fits[i + step][1])
                    if f[0] < fits[i][0] - 1e-6:
                        fits[i] = f
        return np.array([f[0] for f in fits])

    def _learn_rate_scatter(self) -> dict:
        """Relative scatter of the gate-rate calibration, by profile likelihood (a nuisance).

        Prior: log-normal centred on the lab's stated rate error, a factor
        ``RATE_SCATTER_PRIOR_FACTOR`` wide, when the lab states it per setting;
        else log-uniform on [``RATE_SCATTER_MIN``, ``RATE_SCATTER_MAX_FACTOR`` x
        the default error].  On a log grid, each point with the gate nuisances and
        the gate-side effects refitted; the scatter is the root of the posterior
        mean variance.  Held fixed for every hypothesis.
        """
        stated = self.gate.stated_rate_error
        if self.gate.rate_error_stated:
            # the lab's stated error is information: it is known to a factor of
            # about two, not to two decades (a log-uniform prior down to 1e-4 lets a
            # handful of settings pull the scatter far below it, and the gate-side
            # effects then fit the calibration's own scatter)
            k = RATE_SCATTER_PRIOR_FACTOR ** 3
            grid = np.geomspace(stated / k, stated * k, 2 * RATE_SCATTER_POINTS - 1)
            log_prior = -0.5 * (np.log(grid / stated) / np.log(RATE_SCATTER_PRIOR_FACTOR)) ** 2
        else:
            hi = max(RATE_SCATTER_MAX_FACTOR * stated, 2 * RATE_SCATTER_MIN)
            grid = np.geomspace(RATE_SCATTER_MIN, hi, RATE_SCATTER_POINTS)
            log_prior = np.zeros(grid.size)
        nll = self._profile_rate_scatter(grid)
        # marginalised, not maximised: with ten-odd settings the profile is often flat
        # or two-humped (a common offset against a scatter), and its maximum then jumps
        # between the grid's ends.  The rate error enters the likelihood as a Gaussian
        # variance, so the posterior (prior weights on the log grid) is summarised by
        # its mean *variance* (moment-matched predictive).
        lpost = log_prior - 0.5 * nll
        w = np.exp(lpost - lpost.max())
        best = float(np.sqrt(np.sum(w * grid ** 2) / np.sum(w)))
        self._set_rate_scatter(best)
        return {"rel": float(best), "db": self.gate.rate_error_db(),
                "stated_rel": self.gate.stated_rate_error,
                "profile": {f"{v:.3g}": float(n - nll.min()) for v, n in zip(grid, nll)}}

    def _gate_whitened(self, p: dict, logdet: bool = False):
        pr = self.gate.predict(p)
        qs = self.g_obs
        r = np.stack([self.g_meas[q] - pr[q] for q in qs], axis=1)
        return _whiten_settings(r, np.stack([self.g_shot[q] for q in qs], axis=1),
                                np.stack([pr["dlin_" + q] for q in qs], axis=1),
                                np.stack([pr["dquad_" + q] for q in qs], axis=1),
                                pr["v_lin"], pr["v_quad"], logdet=logdet)

    def _tone_features(self, p: dict) -> dict:
        keys = TONE_PARAMS + tuple(self.tone.mode_names)
        key = tuple(float(p.get(k, np.nan)) for k in keys)
        if key != self._cache_key:
            self._cache_key, self._cache_val = key, self.tone.features(p)
        return self._cache_val

    # -------------------------------------------------------------- residuals
    def residuals(self, p: dict, with_prior: bool = True) -> np.ndarray:
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
        out = []
        model = self._tone_features(p) if with_tones else {}
        for name, (v, e) in (self.meas.items() if with_tones else ()):
            m = model[name]
            if name == "gate_power":
                # absolute scale of the tone powers: profiled (weighted mean), 1 parameter
                e = np.sqrt(e ** 2 + self.sig_jit ** 2)
                r = v - m
                ok = np.isfinite(r)
                m = m + (np.sum(r[ok] / e[ok] ** 2) / np.sum(1 / e[ok] ** 2) if ok.any() else 0)
            z = (v - m) / e
            out.append(({"kind": "tones", "observable": name}, z))
        if self.gate is not None:
            pr = self.gate.predict(p)
            qs = self.g_obs
            r = np.stack([self.g_meas[q] - pr[q] for q in qs], axis=1)
            if whiten:
                z = _whiten_settings(r, np.stack([self.g_shot[q] for q in qs], axis=1),
                                     np.stack([pr["dlin_" + q] for q in qs], axis=1),
                                     np.stack([pr["dquad_" + q] for q in qs], axis=1),
                                     pr["v_lin"], pr["v_quad"])
            else:
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
        if with_prior:
            z = np.array([(p.get(k, self.center[k]) - self.center[k]) / s
                          for k, s in self.prior.items() if np.isfinite(s)])
            out.append(({"kind": "prior", "observable": "prior"}, z))
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


def _whiten_settings(r, shot, g, h, v_lin, v_quad, logdet: bool = False):
    """Whitened residuals of each setting's gate observables (shape (n, 3)).

    ``r``: residuals, ``shot``: their shot-noise errors, ``g``, ``h``: the
    settings' responses to the shared random power error (linear and
    quadratic parts, :meth:`dpdfit.analyses.diagnosis.effects.GateModel.predict`), with variances
    ``v_lin``, ``v_quad`` (arrays over settings).  The covariance of one
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


@dataclass(frozen=True)
class FitResult:
    """Best fit of one hypothesis (baseline, an effect or a pair)."""

    effect: str
    params: dict
    params_err: dict
    nuisances: dict
    chi2: float
    n_obs: int
    n_par: int
    chi2_by_observable: dict
    n_by_observable: dict
    #: which form of the effect fitted best (stale_calibration: "table" or "aom")
    variant: str | None = None

    @property
    def dof(self) -> int:
        return max(self.n_obs - self.n_par, 1)

    @property
    def bic(self) -> float:
        return self.chi2 + self.n_par * np.log(self.n_obs)

    @property
    def p_fit(self) -> float:
        return float(chi2_dist.sf(self.chi2, self.dof))

    def redchi(self) -> dict:
        return {k: self.chi2_by_observable[k] / max(self.n_by_observable[k], 1)
                for k in self.chi2_by_observable}


@dataclass(frozen=True)
class _Opt:
    """Optimum of one least-squares run: parameters, cost (chi2/2), Jacobian."""

    x: np.ndarray
    cost: float
    jac: np.ndarray


class _Profile:
    """The calibration modes profiled out linearly around a point (variable projection).

    The tone model depends smoothly on the calibration's error modes
    (``cal_amp*``, ``cal_phase*``; N(0, 1) priors), so around a point
    ``p_lin`` (modes at ``d_lin``) the data residuals are
    ``z(x, d) ~ z(x, d_lin) + J (d - d_lin)``, with ``J`` their Jacobian in
    the modes (forward differences, one model evaluation per mode).  For any
    other parameters ``x`` the modes' optimum is then a ridge solution,
    ``d = -(J^T J + I)^-1 J^T r0`` with ``r0 = z(x, d_lin) - J d_lin``, and
    the profiled residual vector is ``[r0 + J d, d]`` (data, priors).  Its
    sum of squares is the marginal chi2 ``r0^T (I + J J^T)^-1 r0``, so the
    Gauss-Newton errors of ``x`` include the calibration uncertainty (all
    its modes) at the cost of one model evaluation per residual call instead
    of one more Jacobian column per mode.  :func:`_fit` re-linearises at its
    optimum until the modes settle.  Hand-written: a linear profile inside
    ``least_squares`` has no library routine.
    """

    def __init__(self, data_fun, p_lin: dict, modes: list, step: float = PROFILE_STEP):
        self.modes = modes
        self.d_lin = np.array([float(p_lin.get(k, 0.0)) for k in modes])
        z0 = data_fun(p_lin)
        J = np.empty((z0.size, len(modes)))
        for i, k in enumerate(modes):
            J[:, i] = (data_fun({**p_lin, k: self.d_lin[i] + step}) - z0) / step
        self.J = J
        self.M = np.linalg.solve(J.T @ J + np.eye(len(modes)), J.T)

    def point(self, p: dict) -> dict:
        """``p`` with the modes at the linearisation point (where the model is evaluated)."""
        return {**p, **dict(zip(self.modes, self.d_lin))}

    def solve(self, z: np.ndarray):
        """(profiled data residuals, modes) from the data residuals at :meth:`point`."""
        r0 = z - self.J @ self.d_lin
        d = -self.M @ r0
        return r0 + self.J @ d, d


def _effect(prob: Problem, name: str):
    """Catalog effect or variant (:data:`dpdfit.analyses.diagnosis.effects.VARIANTS`) by name; the
    AOM-drift variant of stale_calibration has as many parameters as the campaign has
    run-to-run drift modes."""
    if name == STALE_AOM_KEY:
        return dataclasses.replace(STALE_AOM,
                                   params=STALE_AOM.params[:len(prob.tone.drift_modes)])
    return VARIANTS[name] if name in VARIANTS else EFFECTS[name]


#: name of each catalog effect's own form when it has a variant
_BASE_FORM = {"stale_calibration": "table", "am_pm_omitted": "post", "aom_memory": "fast",
              "dephasing": "independent", "motional_heating": "during"}


def _variant_name(key: str) -> str | None:
    return key.split("@")[1] if "@" in key else _BASE_FORM.get(key)


def _fit(prob: Problem, effects: tuple, starts=None, fixed: dict | None = None,
         init: dict | None = None) -> FitResult:
    """Least-squares fit of the nuisances plus the effects' parameters.

    ``fixed`` holds nuisances at given values (the baseline's): the tone and
    gate sides of the model share no parameter, so an effect on one side is
    fitted with the other side's nuisances held at their baseline optimum,
    which is exact and saves the other side's model evaluations.  The
    calibration modes that are not held are profiled out linearly
    (:class:`_Profile`).
    """
    fixed = dict(fixed or {})
    init = dict(init or {})
    prof = [k for k in prob.tone.mode_names if k not in fixed]
    effect_pars = [par for e in effects for par in _effect(prob, e).params]
    names, lo, hi, x0, scale = [], [], [], [], []
    for k, s in prob.prior.items():
        if k in fixed or k in prof or k in {par.name for par in effect_pars}:
            continue
        c = prob.center[k]
        names.append(k)
        b = prob.bounds.get(k, (c - 50 * s, c + 50 * s))
        lo.append(b[0])
        hi.append(b[1])
        x0.append(c)
        scale.append(s if np.isfinite(s) else 0.1 * (b[1] - b[0]))
    eff_params = []
    for par in effect_pars:
        if True:
            names.append(par.name)
            lo.append(par.lo)
            hi.append(par.hi)
            x0.append(par.start)
            scale.append(par.scale)
            eff_params.append(par.name)
    lo, hi = np.array(lo), np.array(hi)
    x_prior = np.array(x0)                        # nuisances at their prior centre
    far = False
    for k, v in init.items():                     # e.g. nuisances at the baseline's optimum
        if k in names:
            i = names.index(k)
            x0[i] = float(np.clip(v, lo[i], hi[i]))
            far |= k in prob.prior and abs(x0[i] - prob.center[k]) > FAR_NUISANCE * prob.prior[k]
    x0 = np.array(x0)

    def params(x) -> dict:
        return {**fixed, **dict(zip(names, x))}

    def data(p) -> np.ndarray:
        z = prob.residuals(p, with_prior=False)
        return np.where(np.isfinite(z), z, 0.0)

    def prior_z(p) -> np.ndarray:
        return np.array([(p.get(k, prob.center[k]) - prob.center[k]) / prob.prior[k]
                         for k in list(prob.prior) if k not in prof
                         and np.isfinite(prob.prior[k])])

    def linearise(x, d: dict) -> _Profile | None:
        return _Profile(data, {**params(x), **d}, prof) if prof else None

    def make_fun(lin):
        def fun(x):
            p = params(x)
            if lin is None:
                return np.concatenate([data(p), prior_z(p)])
            zd, d = lin.solve(data(lin.point(p)))
            return np.concatenate([zd, prior_z(p), d])
        return fun

    def modes_at(lin, x) -> dict:
        if lin is None:
            return {}
        return dict(zip(prof, lin.solve(data(lin.point(params(x))))[1]))

    # linearised first at the prior centre of the modes (an effect that explains the
    # recordings leaves them near it), then at the optimum
    d_init = {k: 0.0 for k in prof}
    lin0 = linearise(x0, d_init)
    candidates = [np.array(x0)]
    seeds = next((g for k, g in SEED_GRIDS.items() if set(g[0]) <= set(eff_params)), None)
    if seeds is not None:
        # multimodal chi2 surfaces (the memory's: a valley per sign of f_off and local
        # minima along tau x f_off; the thermal memory's along th_tau): seed from a
        # coarse grid (nuisances at their start) and start from the best point of each
        # sign of the grid's second parameter
        (pa, pb), (ga, gb) = seeds
        ia, ib = names.index(pa), names.index(pb)
        fun0 = make_fun(lin0)
        grid = []
        for va in ga:
            for vb in gb:
                x = np.array(x0)
                x[ia], x[ib] = va, vb
                grid.append((float(np.sum(fun0(x) ** 2)), x))
        candidates = [min((g for g in grid if np.sign(g[1][ib]) == sgn),
                          key=lambda g: g[0])[1] for sgn in (-1.0, 1.0)]
    if far:
        # the baseline pushed a nuisance far out (it absorbed part of a strong effect,
        # possibly up to its bound, where the trust region cannot move): also start
        # from the nuisances' prior centre
        is_nuis = np.array([k in prob.prior for k in names])
        candidates += [np.where(is_nuis, x_prior, c) for c in candidates]
    if starts:
        for st in starts:
            x = np.array(x0)
            for k, v in st.items():
                if k in names:
                    x[names.index(k)] = v
            candidates.append(x)
    pad = 1e-6 * (hi - lo)

    def solve(x, lin, nfev=MAX_NFEV):
        # a wrong effect against a strong mismatch converges slowly and is rejected
        # anyway: cap the evaluations (the right one converges in a few); start
        # strictly inside the bounds: a start on a bound can stall the trust region
        fun = make_fun(lin)
        if not names:
            z = fun(np.zeros(0))
            return _Opt(np.zeros(0), 0.5 * float(z @ z), np.zeros((z.size, 0)))
        memo = {}

        def f(x):
            memo["x"], memo["f"] = np.array(x), fun(x)
            return memo["f"]

        def jac(x):
            # forward differences with absolute steps (a fraction of each parameter's
            # scale): scipy's steps are relative to x, which at a start of 0 (every
            # effect's "absent") probes at ~1e-8 and drowns the slope in rounding
            f0 = memo["f"] if "x" in memo and np.array_equal(memo["x"], x) else fun(x)
            J = np.empty((f0.size, x.size))
            for i in range(x.size):
                h = FD_STEP * scale[i] * (1.0 if x[i] + FD_STEP * scale[i] <= hi[i] else -1.0)
                xi = np.array(x, dtype=float)
                xi[i] += h
                J[:, i] = (fun(xi) - f0) / h
            return J

        r = least_squares(f, np.clip(x, lo + pad, hi - pad), jac=jac, bounds=(lo, hi),
                          x_scale=np.array(scale), method="trf",
                          max_nfev=nfev, ftol=1e-8, xtol=1e-8)
        return _Opt(r.x, float(r.cost), r.jac)

    if len(candidates) > 1:
        # several starts: a short run from each, the best one is refined
        screened = []
        for x in candidates:
            try:
                screened.append(solve(x, lin0, SCREEN_NFEV))
            except ValueError:
                continue
        if screened:
            candidates = [min(screened, key=lambda r: r.cost).x]
    best, best_lin = None, None
    for x in candidates:
        lin = linearise(x, d_init) if len(names) and prof else lin0
        try:
            r = solve(x, lin)
            # re-linearise at the optimum until the profiled modes settle
            for _ in range(PROFILE_RELIN):
                if lin is None:
                    break
                d_new = modes_at(lin, r.x)
                if max(abs(d_new[k] - v) for k, v in zip(prof, lin.d_lin)) < PROFILE_TOL:
                    break
                lin = linearise(r.x, d_new)
                r = solve(r.x, lin)
        except ValueError:
            continue
        if best is None or r.cost < best.cost:
            best, best_lin = r, lin
    x = best.x
    J = best.jac
    try:
        cov = np.linalg.pinv(J.T @ J)
        err = np.sqrt(np.clip(np.diag(cov), 0, None))
    except np.linalg.LinAlgError:
        cov = np.full((x.size, x.size), np.nan)
        err = np.full(x.size, np.nan)
    at_bound = (np.isclose(x, lo, rtol=0, atol=1e-9 * np.maximum(1, np.abs(lo)))
                | np.isclose(x, hi, rtol=0, atol=1e-9 * np.maximum(1, np.abs(hi))))
    err = np.where(at_bound, np.nan, err)
    p = {**params(x), **modes_at(best_lin, x)}
    params_ = {k: float(p[k]) for k in eff_params}
    perr = {k: float(err[names.index(k)]) for k in eff_params}
    if "st0" in eff_params:
        # stale table: report the fractional difference of the table's y(A) at A = 0.5
        # (mid gate range, where the spectra constrain it; y(1) is an extrapolation
        # for DPD'd waveforms) by the delta method (dc = st @ modes is linear)
        idx = [names.index(f"st{i}") for i in range(len(prob.tone.stale_modes))]
        a = DRIFT_AT_A
        y_a = float(np.polynomial.polynomial.polyval(a, prob.tone._cy))
        g = prob.tone.stale_modes @ (a ** np.arange(2, 2 + prob.tone.stale_modes.shape[1])) / y_a
        params_ = {"drift": float(g @ np.array([p[names[i]] for i in idx])), **params_}
        perr = {"drift": float(np.sqrt(max(g @ cov[np.ix_(idx, idx)] @ g, 0.0))), **perr}
    if "sa0" in eff_params:
        # the AOM drifted since the table's run: drift = y_table(0.5)/y_today(0.5) - 1
        # (the table's calibration relative to today's AOM, as for the table variant)
        idx = [names.index(f"sa{i}") for i in range(len(prob.tone.drift_modes))]
        a = DRIFT_AT_A
        powers = a ** np.arange(2, 2 + prob.tone.drift_modes.shape[1])
        y_a = float(np.polynomial.polynomial.polyval(a, prob.tone._cy))
        dy = prob.tone.drift_modes @ powers
        y_t = y_a + float(dy @ np.array([p[names[i]] for i in idx]))
        g = -y_a / y_t ** 2 * dy
        params_ = {"drift": y_a / y_t - 1, **params_}
        perr = {"drift": float(np.sqrt(max(g @ cov[np.ix_(idx, idx)] @ g, 0.0))), **perr}
    # chi2 and counts of the model itself at the optimum (modes at their profiled values)
    n_data = int(np.isfinite(prob.residuals(p, with_prior=False)).sum())
    chi_obs, n_obs = {}, {}
    for lab, z in prob.blocks(p, with_prior=False):
        z = z[np.isfinite(z)]
        key = f"{lab['kind']}:{lab['observable']}"
        chi_obs[key] = float(np.sum(z ** 2))
        n_obs[key] = int(z.size)
    z_all = prob.residuals(p)
    z_all = z_all[np.isfinite(z_all)]
    return FitResult(effect="+".join(e.split("@")[0] for e in effects)
                     if effects else "baseline",
                     variant="+".join(v for v in map(_variant_name, effects) if v) or None,
                     params=params_, params_err=perr,
                     nuisances={k: float(p[k]) for k in p if k not in eff_params},
                     chi2=float(np.sum(z_all ** 2)),
                     n_obs=n_data + sum(np.isfinite(v) for v in prob.prior.values()),
                     # every nuisance (fixed ones were fitted in the baseline) + tone offset
                     n_par=len(prob.prior) + 1 + len(eff_params),
                     chi2_by_observable=chi_obs, n_by_observable=n_obs)


@dataclass(frozen=True)
class Diagnosis:
    """Result of :func:`diagnose` (JSON keys of ``dpdfit diagnose --json``)."""

    campaign: str
    mismatches: list
    ranking: list
    verdict: str
    redchi_before: dict
    redchi_after: dict
    baseline: FitResult
    chosen: FitResult | None
    baseline_p_value: float
    seconds: float
    extra: dict = field(default_factory=dict)
    #: residual series (``Problem.series``) of the baseline and the chosen fit, for plots
    series_before: list = field(default_factory=list, repr=False)
    series_after: list = field(default_factory=list, repr=False)

    def to_dict(self) -> dict:
        return {"campaign": self.campaign, "verdict": self.verdict,
                "mismatches": self.mismatches, "ranking": self.ranking,
                "redchi_before": self.redchi_before, "redchi_after": self.redchi_after,
                "baseline_chi2": self.baseline.chi2, "baseline_dof": self.baseline.dof,
                "baseline_p_value": self.baseline_p_value,
                "baseline_nuisances": self.baseline.nuisances,
                "chosen": None if self.chosen is None else {
                    "effect": self.chosen.effect, "params": self.chosen.params,
                    "params_err": self.chosen.params_err, "chi2": self.chosen.chi2,
                    "dof": self.chosen.dof, "p_fit": self.chosen.p_fit},
                "units": {p.name: p.unit for e in EFFECTS.values() for p in e.params},
                "conventions": {"delta_bic": "BIC(effect) - BIC(baseline); negative favours "
                                             "the effect",
                                "p_value": "likelihood-ratio test against the baseline "
                                           "(Wilks, chi2 with the effect's parameter count)",
                                "params_err": "1 sigma, Gauss-Newton (J^T J)^-1",
                                "significance_sigma": "two-sided Gaussian equivalent of the "
                                                      "Bonferroni-corrected p-value"},
                "alpha": ALPHA, "seconds": self.seconds, **self.extra}

    def report(self) -> str:
        lines = [f"Diagnosis of {self.campaign}",
                 f"  baseline chi2 = {self.baseline.chi2:.1f} for {self.baseline.dof} dof "
                 f"(p = {self.baseline_p_value:.2g})",
                 f"  verdict: {self.verdict}", "", "  mismatches located:"]
        if not self.mismatches:
            lines.append("    none")
        for m in self.mismatches[:12]:
            lines.append(f"    {m['observable']:>22s} {m['sideband']:>5s} dpd={m['dpd']:>2} "
                         f"{m['x']}=[{m['range'][0]:.4g}, {m['range'][1]:.4g}] "
                         f"{m['significance_sigma']:.1f} sigma, {m['shape']}")
        lines += ["", "  ranking (delta_bic, LRT p):"]
        for r in self.ranking[:8]:
            par = ", ".join(f"{k}={v:.4g}+/-{r['params_err'][k]:.2g}" for k, v in
                            r["params"].items())
            lines.append(f"    {r['effect']:>40s} {r['delta_bic']:10.1f} {r['p_value']:9.2g}  "
                         f"{par}")
        lines += ["", "  reduced chi2 per observable (before -> after):"]
        for k in self.redchi_before:
            lines.append(f"    {k:>28s} {self.redchi_before[k]:8.2f} -> "
                         f"{self.redchi_after.get(k, float('nan')):8.2f}")
        ex = self.extra or {}
        if ex.get("verdict_fit") == "approximate":
            lines += ["", f"  the named effect's catalog form is approximate: it removes "
                          f"{ex['explained_fraction']:.1%} of the baseline's excess chi2 but "
                          "leaves an unacceptable fit"]
        nm = ex.get("null_model")
        if nm:
            lines += ["", "  null model (learnt from the campaign before any effect):"]
            tn = nm["tone_noise"]
            fl = tn["noise_floor"]
            err = "" if not np.isfinite(fl["floor_err_db"]) else f" +/- {fl['floor_err_db']:.2f}"
            lines.append(f"    noise floor {fl['floor_db']:.2f}{err} dB ({fl['method']})")
            lines.append(f"    tone repeatability {tn['tone_repeatability_db']:.4f} dB, "
                         f"trace power jitter {tn['trace_power_jitter_db']:.4f} dB")
            if nm.get("rate_scatter"):
                rs = nm["rate_scatter"]
                lines.append(f"    gate-rate calibration scatter {rs['rel']:.3%} "
                             f"(stated {rs['stated_rel']:.3%})")
            if nm.get("phase_sign") is not None:
                lines.append(f"    phase-sign convention {nm['phase_sign']:+d}")
            fitted = nm.get("fitted") or {}
            if fitted:
                lines.append("    fitted: " + ", ".join(f"{k}={v:.4g}" for k, v in
                                                       fitted.items()))
        if ex.get("left_out"):
            lines += ["", "  left out (absent from the folder):"]
            lines += [f"    {x}" for x in ex["left_out"]]
        return "\n".join(lines)


def _locate(prob: Problem, p: dict) -> list:
    series = prob.series(p)
    out = []
    for name, sb, d, xname, x, z in series:
        for dev in scan_intervals(x, z, n_series=len(series), alpha=ALPHA):
            out.append({"observable": name, "sideband": sb, "dpd": None if d < 0 else int(d),
                        "x": xname, "range": [dev.lo, dev.hi], "n_points": dev.n_points,
                        "significance_sigma": dev.significance_sigma,
                        "p_global": dev.p_global, "shape": dev.shape,
                        "offset": dev.offset, "slope": dev.slope})
    # red/blue asymmetry: the same feature deviating differently on the two sidebands
    out.sort(key=lambda m: -m["significance_sigma"])
    return out


def mismatch_evidence(p_base: float, mismatches: list, ranking: list) -> list[str]:
    """Which tests say the baseline does not describe the recordings (empty: none).

    ``"global_chi2"``: the baseline's chi2 p-value is below ``ALPHA``;
    ``"located_interval"``: the interval scan found a deviation;
    ``"targeted:<effect>"``: the best single catalog effect's likelihood-ratio
    test, Bonferroni-corrected over the single effects tried, is below
    ``ALPHA`` with ``delta_bic < -BIC_DECISIVE``.  The targeted test sees
    effects too weak or too smooth for the interval scan (slow heating,
    a small power offset).  The correction bounds its false-alarm rate by
    ``ALPHA`` only if the LRT p-values are calibrated (Wilks); that is not
    tested, only observed on the harness's null campaigns.  Only gate-side
    effects count for it (ranking entries with ``side`` "gates"; entries
    without ``side`` count as gate-side): the ~10^3 tone features are read to
    0.01-0.05 dB, finer than any forward model matches another laboratory's
    physics -- on independent null campaigns single tone-side effects with
    parameters too small to matter (a 1-mrad phase, a 3-ns memory) lowered the
    baseline's chi2 by 20-60 -- so a tone-side mismatch must show as a visible
    one: in the global chi2 or a located interval.
    """
    singles = [r for r in ranking if "+" not in r["effect"]]
    gate_side = [r for r in singles if r.get("side", "gates") == "gates"]
    out = []
    if p_base < ALPHA:
        out.append("global_chi2")
    if mismatches:
        out.append("located_interval")
    if gate_side:
        best = min(gate_side, key=lambda r: r["delta_bic"])
        if best["p_value"] * len(singles) < ALPHA and best["delta_bic"] < -BIC_DECISIVE:
            out.append(f"targeted:{best['effect']}")
    return out


def _impact(prob: Problem, f: FitResult) -> float:
    """How much an effect at its fitted parameters matters: the largest change of a
    fidelity at a recorded gate setting (both DPD flags).

    Tone-side effects: the spectral estimate ``F_est`` (S5, from the model's tone
    powers at the setting's amplitude, mean of the sidebands) with and without the
    effect's parameters; gate-side effects: the predicted Bell fidelity
    ``(F_pop + C)/2``.  Without gate settings the spectra's amplitudes >= 0.2 are used.
    """
    p1 = {**f.nuisances, **f.params}
    p0 = {k: v for k, v in p1.items() if k not in f.params}
    names = set(TONE_PARAMS) & set(f.params)
    out = 0.0
    if names:
        if prob.gate is not None:
            amps = sorted({a for a, _ in prob.gate.keys})
        else:
            amps = [a for a in prob.camp.A_tones if a >= 0.2]
        w = synthesize(cardioid(), prob.tone.grid, np.asarray(amps, dtype=float))
        h = [HARMONICS.index(n) for n in (0, 1, 2, 3)]
        F = []
        for p in (p0, p1):
            P = np.stack([prob.tone._tone_dB(prob.tone._field(w, p)[:, d]) for d in (0, 1)],
                         axis=1)                               # (nA, 2 dpd, 2 sb, H)
            F.append(np.array([[np.mean([estimate(P[i, d, sb][h], (0, 1, 2, 3)).F_est
                                         for sb in (0, 1)]) for d in (0, 1)]
                               for i in range(len(amps))]))
        out = float(np.nanmax(np.abs(F[1] - F[0])))
    if prob.gate is not None and set(f.params) - names:
        a, b = prob.gate.predict(p1), prob.gate.predict(p0)
        out = max(out, float(np.nanmax(np.abs((a["F_pop"] + a["C"]) - (b["F_pop"] + b["C"]))
                                        / 2)))
    return out


def _explained(base: FitResult, f: FitResult) -> float | None:
    """Fraction of the baseline's excess chi2 (over its dof) that ``f`` removes;
    None when the baseline has no excess."""
    excess = base.chi2 - base.dof
    return float((base.chi2 - f.chi2) / excess) if excess > 0 else None


def _rank_entry(base: FitResult, f: FitResult, impact: float | None = None) -> dict:
    dchi = base.chi2 - f.chi2
    k = f.n_par - base.n_par
    return {"effect": f.effect, **({"variant": f.variant} if f.variant else {}),
            "side": "+".join(sorted({EFFECTS[e].side for e in f.effect.split("+")})),
            **({"impact": impact} if impact is not None else {}),
            "explained_fraction": _explained(base, f),
            "delta_bic": float(f.bic - base.bic),
            "p_value": float(chi2_dist.sf(max(dchi, 0.0), k)), "delta_chi2": float(dchi),
            "params": f.params, "params_err": f.params_err, "chi2": f.chi2, "dof": f.dof,
            "p_fit": f.p_fit}


def _repredict_gates(prob: Problem, f: FitResult) -> FitResult:
    """A tone-side effect's fit with the gates re-predicted from its field and refitted.

    The tone parameters are held at their fit; the gate nuisances are refitted.  The
    sign convention of the phase response is chosen again here (the tone powers do not
    depend on it, the gates do): both the current sign and the other one (the whole
    AM-to-PM, the effect's ``dphi`` included, sign-flipped) are tried unless the effect
    makes the spectra red/blue asymmetric (AOM memory), and the better gate fit is kept.
    """
    held = {k: v for k, v in {**f.nuisances, **f.params}.items()
            if k in prob.tone_nuisances or k in TONE_PARAMS}
    options = [(prob.tone, held)]
    pm = [k for k in ("dphi", "dphi_x", "th_p") if k in held]
    if "f_off" not in held and (prob.camp.phase is not None or pm):
        other = {**held, **{k: -held[k] for k in pm}}
        options.append((prob.tone.with_phase_sign(-prob.tone.phase_sign), other))
    saved = prob.gate
    best, best_sign = None, None
    try:
        for tone, p in options:
            prob.gate = saved.rebased(tone, p)
            g = _fit(prob, (), fixed=p)
            if best is None or g.chi2 < best.chi2:
                best, best_sign = g, (tone.phase_sign, {k: p[k] for k in pm})
    finally:
        prob.gate = saved
    params = {**f.params, **{k: v for k, v in best_sign[1].items() if k in f.params}}
    return dataclasses.replace(
        best, effect=f.effect, variant=f.variant, params=params, params_err=f.params_err,
        nuisances={**{k: v for k, v in best.nuisances.items() if k not in f.params},
                   "phase_sign": best_sign[0]},
        n_par=f.n_par)


def _other_sign(prob: Problem, name: str, f: FitResult, gate_nuis: dict, init: dict
                ) -> FitResult:
    """An asymmetric (memory) effect refitted under the other phase-sign convention.

    The sign was chosen by the gates *before* any effect (:meth:`Problem._choose_phase_sign`);
    an effect that also spoils the gates can mislead that choice.  For most effects the
    tone powers do not depend on the sign and :func:`_repredict_gates` re-chooses it; a
    memory kernel's spectra do, so here the effect is refitted to the tones under the
    other sign, its gates re-predicted, and the better total chi2 kept (the sign is a
    discrete nuisance of every hypothesis).
    """
    key = f"{name}@{f.variant}" if f.variant and f.variant != _BASE_FORM.get(name) else name
    saved_tone, saved_gate, saved_prior = prob.tone, prob.gate, dict(prob.prior)
    alt = prob.tone.with_phase_sign(-prob.tone.phase_sign)
    try:
        prob.tone, prob._cache_key = alt, None
        # the gate engine's baseline *and* responses for this sign (responses of the
        # other sign's field put the contrast off by tens of sigma)
        prob.gate = GateModel(prob.camp, alt, saved_gate.sig_jit, responses=True)
        prob._set_rate_scatter(saved_gate.rate_rel)
        g = _fit(prob, (key,), starts=[f.params], fixed=gate_nuis, init=init)
        g = _repredict_gates(prob, dataclasses.replace(g, variant=f.variant))
    finally:
        prob.tone, prob.gate, prob._cache_key = saved_tone, saved_gate, None
        prob.prior = saved_prior
    return g if g.chi2 < f.chi2 else f


#: the problem the parallel fits share (set before forking: children inherit it)
_SHARED: dict = {}


def _fit_job(effects: tuple, kw: dict) -> FitResult:
    return _fit(_SHARED["prob"], effects, **kw)


def _fit_all(prob: Problem, jobs: list) -> list:
    """``[_fit(prob, effects, **kw) for effects, kw in jobs]`` over the cores (fork:
    only the job's arguments and result are pickled; same results in any order)."""
    _SHARED["prob"] = prob
    try:
        return pmap(_fit_job, [((e, kw), {}) for e, kw in jobs])
    finally:
        _SHARED.clear()


def diagnose(folder, effects=DEFAULT_EFFECTS, pairs: int = 3, with_gates: bool = True
             ) -> Diagnosis:
    """Diagnose a campaign folder (see module doc and :func:`_diagnose`).

    BLAS runs single-threaded meanwhile: the engine's many small matrix products
    are 1.5x slower with threaded BLAS (measured on the bundled campaign), and the
    independent engine runs use the cores instead (:mod:`dpdfit.core.parallel`).
    """
    with threadpool_limits(limits=1, user_api="blas"):
        return _diagnose(folder, effects, pairs, with_gates)


def _diagnose(folder, effects=DEFAULT_EFFECTS, pairs: int = 3, with_gates: bool = True
              ) -> Diagnosis:
    """Diagnose a campaign folder (see module doc).

    Parameters
    ----------
    folder : path-like
        Campaign folder (``dpdfit simulate-campaign`` layout).
    effects : iterable of str
        Catalog effects to consider (:data:`dpdfit.analyses.diagnosis.effects.EFFECTS`).
    pairs : int
        Fit the pairs of this many best single effects (0: none).
    """
    t0 = time.perf_counter()
    camp = load_campaign(folder)
    prob = Problem(camp, with_gates=with_gates)
    effects = tuple(e for e in effects if with_gates or EFFECTS[e].side == "tones")
    base = _fit(prob, ())
    p_base = base.p_fit
    pb = {**base.nuisances}
    mismatches = _locate(prob, pb)
    tone_nuis = {k: v for k, v in base.nuisances.items() if k in prob.tone_nuisances}
    gate_nuis = {k: v for k, v in base.nuisances.items() if k not in prob.tone_nuisances}

    def other_side(effs):
        sides = {_effect(prob, e).side for e in effs}
        return gate_nuis if sides == {"tones"} else tone_nuis if sides == {"gates"} else {}

    # every single effect and every variant (a catalog effect's other form,
    # dpdfit.analyses.diagnosis.effects.VARIANTS: the better of the two by BIC is the effect's fit),
    # fitted independently, over the cores
    keys = list(effects) + [k for k in VARIANTS if k.split("@")[0] in effects
                            and _effect(prob, k).params]
    done = _fit_all(prob, [((k,), dict(fixed=other_side((k,)), init=base.nuisances))
                           for k in keys])
    fits = {}
    for k, f in zip(keys, done):
        name = k.split("@")[0]
        if name not in fits or f.bic < fits[name].bic:
            fits[name] = f
    def rank_singles():
        return sorted((_rank_entry(base, f, _impact(prob, f)) for f in fits.values()),
                      key=lambda r: r["delta_bic"])

    ranking = rank_singles()
    # the best tone-side effect also changes the gates' spectra: re-predict the
    # gates with its field and refit (tone parameters held at their fit)
    if prob.gate is not None:
        tone_best = next((r["effect"] for r in ranking if EFFECTS[r["effect"]].side == "tones"),
                         None)
        if tone_best is not None and fits[tone_best].bic < base.bic - BIC_DECISIVE:
            fits[tone_best] = _repredict_gates(prob, fits[tone_best])
            if prob.camp.phase is not None and "f_off" in fits[tone_best].params:
                fits[tone_best] = _other_sign(prob, tone_best, fits[tone_best], gate_nuis,
                                              base.nuisances)
            ranking = rank_singles()
    evidence = mismatch_evidence(p_base, mismatches, ranking)
    mismatch = bool(evidence)
    top = [r["effect"] for r in ranking[:pairs]]
    pair_fits = {}
    best_ok = bool(ranking) and ranking[0]["p_fit"] >= ALPHA_FIT
    if mismatch and pairs >= 2 and not best_ok:
        def key(e):
            v = fits[e].variant
            return f"{e}@{v}" if v and v != _BASE_FORM.get(e) else e

        combos = list(itertools.combinations(top, 2))
        done = _fit_all(prob, [((key(a), key(b)), dict(
            starts=[{**fits[a].params, **fits[b].params}],
            fixed=other_side((key(a), key(b))), init=base.nuisances)) for a, b in combos])
        pair_fits = {f"{a}+{b}": f for (a, b), f in zip(combos, done)}
        ranking = sorted(ranking + [_rank_entry(base, f) for f in pair_fits.values()],
                         key=lambda r: r["delta_bic"])
    verdict, chosen, approximate = "none", None, False
    if mismatch:
        verdict = "unexplained"
        singles = [r for r in ranking if "+" not in r["effect"]]
        best = singles[0] if singles else None
        ok = (best is not None and best["delta_bic"] < -BIC_DECISIVE and best["p_value"] < ALPHA)
        if ok and best["p_fit"] >= ALPHA_FIT:
            verdict, chosen = best["effect"], fits[best["effect"]]
        else:
            prs = [r for r in ranking if "+" in r["effect"] and r["delta_bic"] < -BIC_DECISIVE
                   and r["p_fit"] >= ALPHA_FIT]
            if prs and (best is None or prs[0]["delta_bic"] < best["delta_bic"] - BIC_DECISIVE):
                verdict, chosen = prs[0]["effect"], pair_fits[prs[0]["effect"]]
                # a partner that adds < DOMINANT_FRACTION of the improvement only refines
                # the dominant effect's functional form (e.g. a memory kernel that is not
                # exactly single-pole): name the dominant effect, describe with the pair
                if (ok and best["effect"] in verdict.split("+")
                        and prs[0]["delta_chi2"] - best["delta_chi2"]
                        < DOMINANT_FRACTION * best["delta_chi2"]):
                    verdict = best["effect"]
            elif ok and (best["explained_fraction"] or 0.0) >= EXPLAINED_FRACTION:
                # no acceptable fit, but one effect explains nearly all of the mismatch:
                # it is named; its catalog form does not describe the rest (reported)
                verdict, chosen = best["effect"], fits[best["effect"]]
                approximate = True
    after = chosen or base
    pb = {**base.nuisances}
    pa = pb if chosen is None else {**chosen.nuisances, **chosen.params}
    return Diagnosis(campaign=str(folder), mismatches=mismatches, ranking=ranking,
                     verdict=verdict, redchi_before=base.redchi(), redchi_after=after.redchi(),
                     baseline=base, chosen=chosen, baseline_p_value=p_base,
                     seconds=time.perf_counter() - t0,
                     extra={"mismatch_evidence": evidence,
                            "verdict_fit": ("none" if chosen is None else "approximate"
                                            if approximate else "acceptable"),
                            "explained_fraction": (None if chosen is None
                                                   else _explained(base, chosen)),
                            "nuisances": {**{k: NUISANCES[k][0] for k in NUISANCES},
                                          **{k: v[0] for k, v in GATE_NUISANCES.items()}},
                            "null_model": prob.null_model(base),
                            "warnings": list(camp.warnings),
                            "left_out": list(camp.left_out)},
                     series_before=prob.series(pb), series_after=prob.series(pa))


# --------------------------------------------------------------------------- plots


def plot_diagnosis(result: Diagnosis, folder, outdir) -> list[str]:
    """Before/after standardised residuals of every series, one figure per observable kind.

    Writes ``diagnosis_tones.png``, ``diagnosis_gates.png`` (and time scans)
    into ``outdir``: baseline residuals (grey) and residuals under the chosen
    effect (colour), with the located intervals shaded.  Returns the paths.
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from pathlib import Path
    from dpdfit.recordings.outputs import staged_outputs
    before = {(s[0], s[1], s[2]): s for s in result.series_before}
    after = {(s[0], s[1], s[2]): s for s in result.series_after}
    groups = {"tones": [k for k in before if k[0] in (
                  "R10", "R23", "R5lo", "R5hi", "gate_balance", "red_blue", "gate_power")],
              "gates": [k for k in before if k[0] in ("F_pop", "imb", "C", "P00_t", "P11_t")],
              "calibration": [k for k in before if k[0].startswith("calibration")]}
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    with staged_outputs() as stage:
        for g, keys in groups.items():
            if not keys:
                continue
            n = len(keys)
            cols = 4 if n > 4 else n
            rows = -(-n // cols)
            fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.4 * rows), squeeze=False)
            for ax, k in zip(axes.flat, keys):
                _, sb, d, xname, x, z = before[k]
                ax.axhline(0, color="k", lw=0.5)
                ax.plot(x, z, "o", ms=3, color="0.6", label="baseline")
                if k in after and result.chosen is not None:
                    ax.plot(after[k][4], after[k][5], "o", ms=3, color="C3",
                            label=result.chosen.effect)
                for m in result.mismatches:
                    if (m["observable"], m["sideband"], -1 if m["dpd"] is None else m["dpd"]) == k:
                        ax.axvspan(*m["range"], color="C1", alpha=0.2)
                ax.set_title(f"{k[0]} {sb} " + ("" if d < 0 else f"dpd={d}"), fontsize=8)
                ax.set_xlabel(xname, fontsize=7)
                ax.set_ylabel("z", fontsize=7)
                ax.tick_params(labelsize=6)
            for ax in list(axes.flat)[n:]:
                ax.axis("off")
            axes.flat[0].legend(fontsize=6)
            fig.suptitle(f"standardised residuals: baseline vs {result.verdict}", fontsize=9)
            fig.tight_layout()
            name = f"diagnosis_{g}.png"
            fig.savefig(stage(out / name), dpi=110, format="png")
            plt.close(fig)
            paths.append(str(out / name))
    return paths


# --------------------------------------------------------------------------- CLI


def cmd_diagnose(args) -> int:
    import json
    from dpdfit.recordings.outputs import to_jsonable
    import sys
    res = diagnose(args.campaign, pairs=args.pairs)
    for w in res.extra.get("warnings", []):
        print(f"dpdfit: warning: {w}", file=sys.stderr)
    if args.plot:
        plot_diagnosis(res, args.campaign, args.plot)
    if args.json:
        print(json.dumps(to_jsonable(res.to_dict()), indent=2))
    else:
        print(res.report())
    return 0


def add_diagnose_command(subparsers):
    """Register ``dpdfit diagnose CAMPAIGN_DIR [--json] [--plot DIR]``."""
    s = subparsers.add_parser(
        "diagnose", help="locate simulation/recording mismatches and name the missing physics",
        description="Standardised residuals of every observable against the simulation built "
                    "from the campaign's own calibration; interval scan with Bonferroni "
                    "correction; catalog effects fitted and ranked by BIC and likelihood-ratio "
                    "tests; verdict: an effect, 'none' or 'unexplained'.")
    s.add_argument("campaign", metavar="CAMPAIGN_DIR")
    s.add_argument("--json", action="store_true", help="print JSON instead of a report")
    s.add_argument("--plot", metavar="DIR", help="write before/after residual plots into DIR")
    s.add_argument("--pairs", type=int, default=3,
                   help="fit pairs of this many best single effects when there is a mismatch (3)")
    s.set_defaults(func=cmd_diagnose)
    return s
