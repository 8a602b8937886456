"""Gate observables of a campaign: the baseline, its nuisances and the gate-side effects.

Baseline values per setting come from the exact engine (:mod:`dpdfit.models.gate_sim`)
with the lab's error model (dephasing, heating, initial phonons; ``campaign.json``
``error_model``, else the paper's values), each setting's ``eta Omega0`` chosen
so that the engine's gate rate equals the recorded ``xi0`` (the lab's rate
calibration).

The engine is run *once* per setting for the raw outcome probabilities of
every preparation branch (:func:`dpdfit.models.gate_sim.setting_branches`: both ions
right, one a spectator, one flipped), so that preparation and detection enter
exactly and analytically (:func:`dpdfit.models.gate_sim.mix_branches`,
:func:`dpdfit.models.gate_sim.confusion`).  That makes what a lab does not know about
them nuisances of the baseline at no cost:

* ``prep_split`` in [0, 1] -- which part of the lab's known total preparation
  error per ion (``p_prep``, 0.3 % in the paper) is a *spectator* (a level that
  takes no part in the gate, read bright) rather than a *flip* (the wrong qubit
  state, driven); flat prior;
* ``e01``, ``e10`` -- the two detection errors (bright read dark, dark read
  bright): Gaussian priors centred on the lab's ``p_det`` (5e-5) with sigma
  ``DETECTION_PRIOR_SIGMA`` (1e-4), clipped at 0.

Gate-side effects (:mod:`dpdfit.analyses.diagnosis.effects`) act through their
hooks: the engine's linear responses to their *knobs* (finite differences of
the two-ion branch at every setting and scan time) weighted per observation
time, a power offset per setting (quadratic response, which also carries the
lab's known per-scan jitter and rate-calibration scatter: the three
observables of a setting share that error, :meth:`GateModel.predict`), and
the preparation and detection errors.  Contrasts are the ``cos 2 phi``
amplitude of the predicted fringe on 16 phases (exact: the spectator branches
add ``cos phi`` terms, orthogonal on that grid).

The engine runs at ``ENGINE_PRECISION``: probabilities to ~1e-5, two orders
below the shot noise of a campaign's pooled scans.  Its runs go through
:func:`~dpdfit.analyses.diagnosis.model.gates.engine_runs.run_settings`, which keeps every
branch's outcome: a model rebased on a field already seen (:meth:`GateModel.rebased`,
e.g. a tone-side fit carried to the gates again) integrates nothing.  The measured
probabilities are mixed in :mod:`~dpdfit.analyses.diagnosis.model.gates.observe`.
"""

from __future__ import annotations

import copy

import numpy as np

from dpdfit.analyses.diagnosis.effects import EFFECTS, Prep
from dpdfit.analyses.diagnosis.effects.dephasing import INDEPENDENT
from dpdfit.analyses.diagnosis.model.caches import ModelCache
from dpdfit.analyses.diagnosis.model.gates.effect_terms import (active_effects,
                                                                effect_terms, preparation)
from dpdfit.analyses.diagnosis.model.gates.engine_runs import run_settings
from dpdfit.analyses.diagnosis.model.gates.knob_response import (KNOB_MULTIPLES,
                                                                 POWER_STEP_DB,
                                                                 response_tables)
from dpdfit.analyses.diagnosis.model.gates.observe import (PHASES, collapse, confusion_t,
                                                           contrast, observe)
from dpdfit.analyses.diagnosis.model.ramsey_block import recorded_coherence
from dpdfit.core.defaults import ERROR_MODEL
from dpdfit.models import gate_sim

__all__ = ["GateModel", "GATE_NUISANCES", "DETECTION_PRIOR_SIGMA", "PHASES", "ENGINE_PRECISION",
           "POWER_STEP_DB"]

#: engine tolerances for the diagnosis: DOP853 tolerances and the population neglected
#: in the thermal tail and above the Fock cutoff
ENGINE_PRECISION = {"rtol": 1e-4, "atol": 1e-6, "fock_tol": 1e-6}
_XI_STEP = 0.01
#: prior sigma of each detection error around the lab's p_det
DETECTION_PRIOR_SIGMA = 1e-4
#: gate-side nuisances: name -> (unit, meaning)
GATE_NUISANCES = {
    "prep_split": ("1", "fraction of the known preparation error that is a spectator "
                        "(rest: a flip); flat prior on [0, 1]"),
    "e01": ("probability", "detection error, bright read dark (prior N(p_det, 1e-4))"),
    "e10": ("probability", "detection error, dark read bright (prior N(p_det, 1e-4))"),
}


class GateModel:
    """Predicted gate observables as functions of the nuisances and effect parameters.

    Parameters
    ----------
    camp : dpdfit.analyses.diagnosis.observables.campaign.Campaign
    tone : dpdfit.analyses.diagnosis.model.tones.tone_model.ToneModel
        Gives each setting's gate tones.
    sig_jit : float
        Per-scan laser-power jitter (dB).
    effects : iterable of str
        The gate-side effects whose knobs get engine responses.
    """

    def __init__(self, camp, tone, sig_jit: float, effects=(), responses: bool = True):
        em = camp.error_model
        self.em = em
        self.nominal = dict(nbar=float(em["nbar"]), T2=float(em["T2_s"]),
                            ndot=float(em["heating_quanta_per_s"]), T2_corr=np.inf)
        self.p_total = float(em["p_prep"])
        self.p_det = float(em["p_det"])
        self.sig_jit = float(sig_jit)
        g = camp.gates
        self.gates, self.folder = g, getattr(camp, "folder", None)
        self.ts = camp.time_scans
        self.keys = [(float(r.A), int(r.dpd)) for r in g.itertuples()]
        self.xi = {k: float(x) for k, x in zip(self.keys, g.xi0_hz)}
        self.A_settings = np.array([k[0] for k in self.keys])
        #: reference amplitude and gate time of the effects' parametrisations
        self.A_ref = float(np.mean(self.A_settings))
        self.t_ref = float(np.median(1.0 / g.xi0_hz.to_numpy(dtype=float)))
        self.T_gate = 1.0 / g.xi0_hz.to_numpy(dtype=float)
        # time scans: their settings (with the rate of the matching gate setting)
        self.ts_keys = []
        if self.ts is not None:
            for (A, d), _ in self.ts.groupby(["A", "dpd"], sort=False):
                key = (float(A), int(d))
                self.ts_keys.append(key)
                if key not in self.xi:
                    # a time scan at a setting without gate data: its rate from the tones
                    self.xi[key] = None
        self.effects = tuple(e for e in effects if EFFECTS[e].side == "gates")
        knobs = {}
        for name in self.effects:
            for k in EFFECTS[name].knobs():
                if k.key in knobs and knobs[k.key] != k:
                    raise ValueError(f"two effects define knob {k.key!r} differently")
                knobs[k.key] = k
        if getattr(camp, "ramsey", None) is not None:
            # the recorded coherence time acts through the independent dephasing rate
            knobs.setdefault(INDEPENDENT.key, INDEPENDENT)
        self.knobs = knobs
        self.tone = tone
        self.base = self._base_runs(tone, {})
        self.resp = None
        self.db_per_rel_xi = 10 / np.log(10)        # rate ~ power, until measured
        self._tab = self._stk = None
        if responses:
            self.compute_responses()

    def compute_responses(self) -> None:
        """Engine runs of every knob and of the power error at every setting (the
        expensive part).

        Until they are computed the model predicts the baseline means only (no effects,
        no power-error variance): enough to choose among baselines.
        """
        self.resp = self._response_runs()
        # power error (dB) equivalent to a relative gate-rate error, from the imbalance
        # of the (first) time-scan setting
        key = self.ts_keys[0] if self.ts_keys else self.keys[0]
        n, b, c, eO, xi = self._tones[key]
        run = gate_sim.setting_branches(b, c, n, eO, xi * (1 + _XI_STEP), **self.nominal,
                                        phases=PHASES, spectator=False, flip=False,
                                        **ENGINE_PRECISION)
        base_imb = collapse(self.base[key]["p2"][0])[1]
        d_xi = (collapse(run["p2"][0])[1] - base_imb) / _XI_STEP
        lin = (collapse(self.resp[key]["eps+"]["p2"][0])[1]
               - collapse(self.resp[key]["eps-"]["p2"][0])[1]) / (2 * POWER_STEP_DB)
        self.db_per_rel_xi = float(abs(d_xi / lin))
        self._tab = self._stk = None

    # ------------------------------------------------------------------ engine
    def _scan_times(self, key):
        if self.ts is None:
            return None
        sel = np.isclose(self.ts.A, key[0]) & (self.ts.dpd == key[1])
        t = self.ts.loc[sel, "t_s"].to_numpy()
        return t[t > 0] if (t > 0).any() else None

    def _base_runs(self, tone, p: dict, two_ion_only: bool = False) -> dict:
        """Raw branch outcomes at every setting for the field of tone parameters ``p``
        (``two_ion_only``: the two-ion branch, the others kept from the current runs)."""
        self._tones = getattr(self, "_tones", {})
        ref = self.keys[0]
        keys = list(dict.fromkeys(self.keys + self.ts_keys))
        calls = []
        for key in keys:
            n, b, c = tone.gate_tones(p, *key)
            unit = gate_sim.calibrate_xi0(b, c, n, 1.0)
            xi = self.xi[key]
            if xi is None:                          # same eta Omega0 as the first setting
                xi = self._tones[ref][3] * unit
            self._tones[key] = (n, b, c, xi / unit, xi)
            calls.append(((b, c, n, xi / unit, xi), dict(
                **self.nominal, phases=PHASES, scan_times=self._scan_times(key),
                **({"spectator": False, "flip": False} if two_ion_only else {}),
                **ENGINE_PRECISION)))
        runs = dict(zip(keys, run_settings(calls, keys, self.folder)))
        if two_ion_only:
            runs = {k: {**self.base[k], **r} for k, r in runs.items()}
        return runs

    def _response_runs(self) -> dict:
        """Two-ion branch at every setting with the power and each knob stepped."""
        calls, where = [], []
        for key in dict.fromkeys(self.keys + self.ts_keys):
            n, b, c, eO, xi = self._tones[key]
            kw = dict(phases=PHASES, scan_times=self._scan_times(key), spectator=False,
                      flip=False, **ENGINE_PRECISION)
            for name, sign in (("eps+", 1), ("eps-", -1)):
                calls.append(((b, c, n, eO, xi), dict(**self.nominal, **kw,
                                                      power_error_db=sign * POWER_STEP_DB)))
                where.append((key, name))
            for knob in self.knobs.values():
                for mult in (KNOB_MULTIPLES if knob.nonlinear else KNOB_MULTIPLES[:1]):
                    calls.append(((b, c, n, eO, xi),
                                  dict(**knob.perturb(self.nominal, mult * knob.step), **kw)))
                    where.append((key, (knob.key, mult)))
        out = {}
        for (key, name), run in zip(where, run_settings(calls, [w[0] for w in where],
                                                        self.folder)):
            out.setdefault(key, {})[name] = run
        return out

    def rebased(self, tone, p: dict, two_ion_only: bool = False) -> "GateModel":
        """A copy whose baseline values use the field of tone-side parameters ``p``
        (e.g. AOM memory changes every setting's spectrum); responses are kept
        (``two_ion_only``: only the two-ion branch is rerun, enough to compare fields)."""
        new = copy.copy(self)
        new._tones = dict(self._tones)
        new.base = new._base_runs(tone, p, two_ion_only)
        new._tab = new._stk = None
        return new

    # ------------------------------------------------------------------ tables
    @property
    def stated_rate_error(self) -> float:
        """The lab's stated relative gate-rate error (median ``xi0_err/xi0``, else the
        error model's ``xi0_rel_err``)."""
        rel = self.gates.xi0_rel_err.to_numpy(dtype=float)
        return (float(np.nanmedian(rel)) if np.isfinite(rel).any()
                else float(self.em.get("xi0_rel_err", ERROR_MODEL.xi0_rel_err)))

    @property
    def rate_error_stated(self) -> bool:
        """Whether the lab states each setting's gate-rate error (``xi0_err_khz``)."""
        return bool(np.isfinite(self.gates.xi0_rel_err.to_numpy(dtype=float)).any())

    def set_rate_scatter(self, rel: float) -> None:
        """Relative scatter of the settings' gate-rate calibrations (a nuisance)."""
        self.rate_rel = float(rel)
        self._tab = None

    def _tables(self):
        if self._tab is not None:
            return self._tab
        g = self.gates
        self._tab = tab = dict(self._stacks())
        vj = self.sig_jit ** 2
        ns = g.n_scans.to_numpy(dtype=float)
        vx = self.rate_error_db() ** 2 / self._n_rates(self.keys)   # pooled: 1/n of one
        tab["var"] = (vj / ns + vx, 2 * (vj ** 2 / ns + vx ** 2))
        return tab

    def _stacks(self):
        if self._stk is None or self._stk[0] is not self.base:
            ts = []
            for key in self.ts_keys:
                ts.append((key, self._scan_times(key),
                           response_tables(self.base, self.resp, self.knobs, [key], "scan")))
            gate = response_tables(self.base, self.resp, self.knobs, self.keys, "gate")
            self._stk = (self.base, {"gate": gate, "ts": ts})
        return self._stk[1]

    # ------------------------------------------------------------------ predict
    def preparation(self, p: dict, active=None) -> Prep:
        """Preparation and detection errors per ion at parameters ``p`` (nuisances and
        effects; :func:`~dpdfit.analyses.diagnosis.model.gates.effect_terms.preparation`)."""
        return preparation(self, p, active_effects(self.effects, p) if active is None
                           else active)

    def predict(self, p: dict) -> dict:
        """Predicted gate observables and their model-side variances.

        Returns dict with arrays over the settings (order of ``camp.gates``):
        ``F_pop, imb, C``, their model-side variances ``var_*`` (known random
        power errors), the shared directions of those errors ``dlin_*``
        (``d/d eps`` at ``eps``, per dB) and ``dquad_*`` (half the second
        derivative), with weights ``v_lin`` (dB^2) and ``v_quad`` (dB^4): the
        three observables of one setting see the *same* power errors, so their
        model-side covariance is ``v_lin dlin dlin^T + v_quad dquad dquad^T``;
        and over the time-scan points (``t > 0``, concatenated over scans):
        ``P00_t, P11_t``.  Time scan ``k`` also takes ``eps_ts{k}``, its own
        gate-rate error (dB).
        """
        tab = self._tables()
        active = active_effects(self.effects, p) + recorded_coherence(self, p)
        prep = preparation(self, p, active)
        # what the effects' values alone fix (effect_terms), kept per values: a fit's
        # Jacobian moves the nuisances far more often than them; with the preparation
        # mixers made for them per preparation error (the detection errors act after them)
        memo = self._stacks().get("parts")
        if memo is None:
            memo = self._stacks()["parts"] = ModelCache()
        key = tuple((e.name, tuple(sorted(v.items()))) for e, v in active)
        parts = memo.get(key)
        if parts is None:
            parts = memo[key] = {**effect_terms(self, active, tab), "mixers": ModelCache()}
        det = confusion_t(prep)
        mix_key = (prep.spectator, prep.flip)                # what the mixers depend on
        mixers = parts["mixers"].get(mix_key)
        if mixers is None:
            mixers = parts["mixers"][mix_key] = {"gate": {}, "ts": [{} for _ in tab["ts"]]}
        # the fixed branches' terms of the mixers, the same for every parameter set
        stacks = self._stacks()
        fixed = stacks.get("branch_terms")
        if fixed is None:
            fixed = stacks["branch_terms"] = {"gate": {}, "ts": [{} for _ in tab["ts"]]}
        # the gate settings' values depend on the effects and the preparation only (not
        # on the time scans' rate errors, which a fit moves as often): kept per both, with
        # the variances (in the tables, which a new rate scatter remakes)
        memo_gate = tab.get("gate_values")
        if memo_gate is None:
            memo_gate = tab["gate_values"] = ModelCache(shared=True)
        gate_key = (key, (prep.spectator, prep.flip, prep.e01, prep.e10))
        res = memo_gate.get(gate_key)
        if res is None:
            res = memo_gate[gate_key] = self._gate_values(tab, parts, prep, det,
                                                          mixers["gate"], fixed["gate"])
        res = dict(res)
        acc = {"P00_t": [], "P11_t": []}
        for k, (key, times, (b, dd, li, qu)) in enumerate(tab["ts"]):
            c_t, e_t, terms_t = parts["ts"][k]
            e = e_t + float(p.get(f"eps_ts{k}", 0.0))
            pop, _ = observe(b, dd, li, qu, c_t, e, 0.0, prep, False, terms=terms_t, det=det,
                             mixers=mixers["ts"][k], fixed=fixed["ts"][k])
            acc["P00_t"].append(pop[0, :, 0])
            acc["P11_t"].append(pop[0, :, 3])
        for q, v in acc.items():
            if v:
                res[q] = np.concatenate(v)
        return res

    @staticmethod
    def _gate_values(tab, parts, prep, det, mixers, fixed) -> dict:
        """The gate settings' part of :meth:`predict`."""
        coefs, eps, coh, terms = parts["gate"]
        v_mean, v_quad = tab["var"]
        base, d, lin, quad = tab["gate"]
        h = POWER_STEP_DB / 3
        vals = {}
        # the three power errors at once (along a leading axis): the same values as
        # three calls, at a third of numpy's per-call cost
        pop, par = observe(base, d, lin, quad, coefs, np.stack([eps, eps + h, eps - h]),
                           v_mean, prep, True, coh, terms, det, mixers, fixed)
        F, imb = collapse(pop)
        C = contrast(par)
        for i, s in enumerate(("0", "+", "-")):
            vals[s] = {"F_pop": F[i], "imb": imb[i], "C": C[i]}
        res = {}
        for q in ("F_pop", "imb", "C"):
            res[q] = vals["0"][q]
            dl = (vals["+"][q] - vals["-"][q]) / (2 * h)
            dq = (vals["+"][q] + vals["-"][q] - 2 * vals["0"][q]) / (2 * h * h)
            res["dlin_" + q] = dl
            res["dquad_" + q] = dq
            res["var_" + q] = dl ** 2 * v_mean + dq ** 2 * v_quad
        res["v_lin"], res["v_quad"] = v_mean, v_quad
        return res

    def bell_fidelity(self, p: dict) -> np.ndarray:
        """Predicted Bell fidelity ``(F_pop + C)/2`` at every gate setting."""
        r = self.predict(p)
        return (r["F_pop"] + r["C"]) / 2

    @property
    def n_time_scans(self) -> int:
        """Number of time-scan settings ``(A, dpd)`` the model predicts."""
        return len(self.ts_keys)

    def rate_error_db(self, key=None) -> float:
        """1-sigma power-equivalent error (dB) of one setting's gate-rate calibration; with
        ``key`` (a setting ``(A, dpd)``), of that setting's rate, which may be pooled from
        ``n_rates`` repeated calibrations (``1/sqrt(n_rates)`` of one)."""
        rel = getattr(self, "rate_rel", None)
        one = float(self.db_per_rel_xi * (self.stated_rate_error if rel is None else rel))
        return one if key is None else float(one / np.sqrt(self._n_rates([key])[0]))

    def _n_rates(self, keys) -> np.ndarray:
        """Calibrations pooled into the rate of each setting of ``keys`` (1 without the
        count, or for a time scan's setting without gate data: its rate is the tones')."""
        g = self.gates
        n = dict(zip(self.keys, g["n_rates"] if "n_rates" in g else np.ones(len(g))))
        return np.array([float(n.get(tuple(k), 1.0)) for k in keys])
