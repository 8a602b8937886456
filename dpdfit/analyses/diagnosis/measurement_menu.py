"""The menu of further recordings, each predicted under each hypothesis in reach.

The predictions behind :func:`~dpdfit.analyses.diagnosis.next_measurement.propose_next_measurement`
(its module doc lists the items, their noise and the expected separation): one
builder per kind, each returning ``(what, settings, lab seconds, separations)``
with the separations (Asimov delta chi2) of the first hypothesis from each other.
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.effects import EFFECTS, effect_of_key
from dpdfit.analyses.diagnosis.effects.active import ActiveEffects
from dpdfit.analyses.diagnosis.observables import MIN_SNR_DB, tone_features
from dpdfit.analyses.diagnosis.phase_sign import tone_held
from dpdfit.core.defaults import ERROR_MODEL, PHASE_MIN_A, PHASE_RUN_NOISE_RAD

__all__ = ["Hypothesis", "BUILDERS", "SPECTRA_GRID", "SPECTRA_COUNTS", "RUN_AMPLITUDES"]

#: amplitudes a spectra recording may choose from
SPECTRA_GRID = np.round(np.linspace(0.05, 1.0, 20), 4)
#: numbers of amplitudes of the spectra items of the menu (each with and without DPD)
SPECTRA_COUNTS = (1, 2, 4)
#: amplitudes of a calibration run (the campaigns' runs: 101 points on [0, 1])
RUN_AMPLITUDES = np.linspace(0.0, 1.0, 101)


# ----------------------------------------------------------------- hypotheses
class Hypothesis:
    """One fit's parameter set, its tone model (phase-sign convention) and, on demand,
    its gate model (rebased on its field when it has tone-side effects)."""

    def __init__(self, prob, fit):
        self.prob, self.fit, self.p = prob, fit, fit.all_params
        tone = getattr(prob, "tone", None)
        sign = int(fit.nuisances.get("phase_sign", 1 if tone is None else tone.phase_sign))
        self.tone = (tone if tone is None or sign == tone.phase_sign
                     else tone.with_phase_sign(sign))
        self._gate = None

    @property
    def gate(self):
        """The gate model of this hypothesis (rebased on its field when it has tone-side
        effects or another phase-sign convention), made on first use."""
        if self._gate is None:
            held = tone_held(self.prob, self.fit)
            tone_effect = any(effect_of_key(k) is not None for k in held)
            self._gate = (self.prob.gate.rebased(self.tone, held)
                          if tone_effect or self.tone is not self.prob.tone else self.prob.gate)
        return self._gate


def _pairs(hyps, mean, sigma):
    """Separation of the first hypothesis from each other, means ``mean(h)``, noise ``sigma``."""
    ms = [mean(h) for h in hyps]
    return np.array([_chi2(ms[0], m, sigma) for m in ms[1:]])


def _chi2(ma, mb, sigma) -> float:
    z = (np.asarray(ma, float) - np.asarray(mb, float)) / sigma
    return float(np.sum(z[np.isfinite(z)] ** 2))


# ----------------------------------------------------------------- calibration runs
def _amplitude_run(prob, hyps, lab):
    modes = getattr(getattr(prob, "tone", None), "drift_modes", None)
    if modes is None or len(modes) == 0:
        return []
    ra = prob.runs_after
    days = np.array([float(np.max(ra.days)) if ra is not None else 0.0])
    sd = np.asarray(ra.sd, float) if ra is not None else np.ones(len(modes))

    def mean(h):
        shift = np.zeros((1, len(modes)))
        for e in EFFECTS.values():
            v = e.values(h.p)
            s = None if v is None else e.run_drift(prob, v, days)
            if s is not None:
                shift = shift + s
        return shift[0]

    return [("amplitude_run", {"runs": 1}, lab.amplitude_run_s, _pairs(hyps, mean, sd))]


def _phase_run(prob, hyps, lab):
    if getattr(prob, "tone", None) is None:
        return []
    A = RUN_AMPLITUDES[RUN_AMPLITUDES >= PHASE_MIN_A]
    noise = (getattr(prob.camp, "calibration_noise", None) or {}).get("phase")
    sigma = (np.hypot(noise["c"], noise["d"] / A) if noise
             else np.full(A.size, PHASE_RUN_NOISE_RAD))

    def mean(h):
        cp = h.tone._coefficients(h.p, ActiveEffects(h.tone, h.p))[1]
        return h.tone.phase_sign * (np.polynomial.polynomial.polyval(A, cp) - cp[0])

    return [("phase_run", {"runs": 1}, lab.phase_run_s, _pairs(hyps, mean, sigma))]


# ----------------------------------------------------------------- spectra
def _tone_sd(prob, P):
    """Error (dB) of recorded tone powers ``P`` (dB): the learnt repeatability with the
    noise floor's part; NaN below the usable SNR."""
    noise = prob.tone_noise
    N0 = float(noise.floor.N0)
    lin = 10 ** (P / 10)
    snr = 10 * np.log10(lin + N0) - 10 * np.log10(N0 * np.log(2))
    sd = np.hypot(noise.s_tone_db, 10 / np.log(10) * np.sqrt(2 * N0 / lin))
    return np.where(snr >= MIN_SNR_DB, sd, np.nan)


def _spectra_contributions(prob, hyps) -> np.ndarray:
    """Delta chi2 of one trace pair (both DPD flags) at each amplitude of
    :data:`SPECTRA_GRID`, first hypothesis against each other: (n others, n amplitudes)."""
    A = SPECTRA_GRID
    P = [h.tone.tone_powers_at(A, h.p) for h in hyps]
    out = []
    for Pb in P[1:]:
        sd = _tone_sd(prob, (P[0] + Pb) / 2)
        fa, fb = tone_features(P[0], A, sd), tone_features(Pb, A, sd)
        c = np.zeros(A.size)
        for name, (va, e) in fa.items():
            if name == "gate_power":
                continue
            z = (va - fb[name][0]) / e
            c += np.nansum(z.reshape(A.size, -1) ** 2, axis=1)
        out.append(c)
    return np.array(out)


def _spectra(prob, hyps, lab):
    if getattr(prob, "tone", None) is None or getattr(prob, "tone_noise", None) is None:
        return []
    c = _spectra_contributions(prob, hyps)
    items = []
    for k in SPECTRA_COUNTS:
        chosen, total = [], np.zeros(c.shape[0])
        for _ in range(min(k, SPECTRA_GRID.size)):
            # greedy: the amplitude that raises the smallest separation most
            gain = np.min(total[:, None] + c, axis=0)
            gain[chosen] = -np.inf
            j = int(np.argmax(gain))
            chosen.append(j)
            total = total + c[:, j]
        amps = sorted(float(a) for a in SPECTRA_GRID[chosen])
        items.append(("spectra", {"amplitudes": amps, "dpd": [0, 1]},
                      2 * len(amps) * lab.spectrum_trace_s, total))
    return items


# ----------------------------------------------------------------- gate recordings
def _typical_shots(prob) -> int:
    g = prob.gate.gates
    return int(np.round(np.median(g["shots"].to_numpy(float) / g["n_scans"].to_numpy(float))))


def _gate_scans(prob, hyps, lab):
    if getattr(prob, "gate", None) is None or prob.gate.gates is None \
            or len(prob.gate.gates) == 0:
        return []
    g = prob.gate
    N = _typical_shots(prob)
    n_par = N * int(ERROR_MODEL.parity_phases)
    v_lin = g.sig_jit ** 2 + g.rate_error_db() ** 2
    v_quad = 2 * (g.sig_jit ** 4 + g.rate_error_db() ** 4)
    preds = [h.gate.predict(h.p) for h in hyps]
    pops = ("F_pop", "imb") if prob.camp.has_imbalance else ("F_pop",)
    sep_pop = np.array([_setting_chi2(preds[0], pb, pops, N, v_lin, v_quad)
                        for pb in preds[1:]])
    sep_par = np.array([_setting_chi2(preds[0], pb, ("C",), n_par, v_lin, v_quad)
                        for pb in preds[1:]])
    items = []
    for i, (A, d) in enumerate(g.keys):
        items.append(("populations", {"A": float(A), "dpd": int(d), "shots": N},
                      N * lab.shot_s, sep_pop[:, i]))
        items.append(("parity", {"A": float(A), "dpd": int(d), "shots": n_par},
                      n_par * lab.shot_s, sep_par[:, i]))
    return items


def _setting_chi2(pa: dict, pb: dict, qs: tuple, N: float, v_lin: float,
                  v_quad: float) -> np.ndarray:
    """Mahalanobis delta chi2 per setting of one new scan of ``N`` shots observing ``qs``:
    shot noise at the pair's mean plus the scan's shared random power error."""
    mean = {q: (pa[q] + pb[q]) / 2 for q in ("F_pop", "imb", "C")}
    F = np.clip(mean["F_pop"], 0.5 / N, 1 - 0.5 / N)
    imb = np.clip(mean["imb"], -F, F)
    C = np.clip(mean["C"], -1.0, 1.0)
    shot = {("F_pop", "F_pop"): F * (1 - F), ("imb", "imb"): F - imb ** 2,
            ("F_pop", "imb"): imb * (1 - F), ("imb", "F_pop"): imb * (1 - F),
            ("C", "C"): 2 * (1 - 0.75 * C ** 2)}
    g = np.stack([(pa["dlin_" + q] + pb["dlin_" + q]) / 2 for q in qs], axis=1)
    h = np.stack([(pa["dquad_" + q] + pb["dquad_" + q]) / 2 for q in qs], axis=1)
    cov = (np.stack([np.stack([shot[(a, b)] / N for b in qs], axis=-1) for a in qs], axis=-2)
           + v_lin * np.einsum("ij,ik->ijk", g, g) + v_quad * np.einsum("ij,ik->ijk", h, h))
    r = np.stack([pa[q] - pb[q] for q in qs], axis=1)
    ok = np.all(np.isfinite(r), axis=1) & np.all(np.isfinite(cov), axis=(1, 2))
    out = np.zeros(r.shape[0])
    if ok.any():
        sol = np.linalg.solve(cov[ok], r[ok][..., None])[..., 0]
        out[ok] = np.einsum("ij,ij->i", r[ok], sol)
    return out


def _time_scans(prob, hyps, lab):
    if getattr(prob, "gate", None) is None or getattr(prob, "ts", None) is None \
            or not prob.gate.ts_keys:
        return []
    ts = prob.ts
    N = int(np.round(np.median(ts["shots"].to_numpy(float))))
    preds = [h.gate.predict(h.p) for h in hyps]
    if any("P00_t" not in pr for pr in preds):
        return []
    items = []
    for A, d in prob.gate.ts_keys:
        sel = (np.isclose(ts["A"].to_numpy(float), A) & (ts["dpd"].to_numpy() == d))
        ms = [np.concatenate([pr["P00_t"][sel], pr["P11_t"][sel]]) for pr in preds]
        seps = []
        for mb in ms[1:]:
            pm = np.clip((ms[0] + mb) / 2, 0.5 / N, 1 - 0.5 / N)
            seps.append(_chi2(ms[0], mb, np.sqrt(pm * (1 - pm) / N)))
        points = int(sel.sum())
        items.append(("time_scan", {"A": float(A), "dpd": int(d), "shots": N,
                                    "points": points},
                      points * N * lab.shot_s, np.array(seps)))
    return items


#: the builders of the menu, in the order the menu lists them
BUILDERS = (_amplitude_run, _phase_run, _spectra, _gate_scans, _time_scans)
