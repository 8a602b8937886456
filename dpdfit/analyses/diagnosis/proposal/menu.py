"""The menu of further recordings, each predicted under each hypothesis in reach.

The predictions behind :func:`~dpdfit.analyses.diagnosis.proposal.next_measurement.propose_next_measurement`
(its module doc lists the items and their noise).  One builder per kind returns
:class:`Item` objects: what the recording is, its lab time, which side of the model
predicts it, and how to read its predicted values (:meth:`Item.vector`) from a
hypothesis's *source* -- the spectra on a grid of amplitudes, the gate model's
predictions, the calibration runs' drift, the phase curve -- at any parameter set
(:meth:`Hypothesis.raw`, memoised, so the items of one source share the model
evaluations their Jacobians need) and its noise at a pair of hypotheses
(:meth:`Item.whitener`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from dpdfit.analyses.diagnosis.observables.phase_runs_after import drift_shape, phase_whitener
from dpdfit.analyses.diagnosis.observables.tone_features import MIN_SNR_DB, tone_features
from dpdfit.analyses.diagnosis.observables.detector_linearity import campaign_power_noise
from dpdfit.analyses.diagnosis.proposal.hypotheses import (LINEARITY_DRIVES, SPAM_STATES,
                                                           SPECTRA_GRID, Hypothesis,
                                                           linearity_readings,
                                                           phase_run_amplitudes,
                                                           pulse_amplitude)
from dpdfit.analyses.diagnosis.proposal.pooled_scans import pooled_whitener, scan_whitener
from dpdfit.core.defaults import ERROR_MODEL, LINEARITY_ATTENUATION_DB, PHASE_RUN_NOISE_RAD
from dpdfit.models.ramsey import SCAN_POINTS, SEQUENCES, scan_waits
from dpdfit.models.sideband_thermometry import SIDEBANDS, THERMOMETRY_WAITS_US

__all__ = ['Item', 'white', 'BUILDERS', 'SPECTRA_COUNTS', 'SPAM_SHOTS', 'PULSE_REL_NOISE',
           'pulse_relative_noise', 'RAMSEY_SHOTS', 'ramsey_seconds', 'THERMOMETRY_SHOTS']


#: numbers of amplitudes of the spectra items of the menu (each with and without DPD)
SPECTRA_COUNTS = (1, 2, 4)
#: shots per prepared state of one SPAM characterisation of the menu (repeated as needed)
SPAM_SHOTS = 1000
#: relative noise of one sample of an AOM pulse response without one of the campaign's
#: own: the simulator's photodiode near half power (a floor of 5e-4 and 1e-3 of the
#: power, at ~1.1 of its 2 at full drive), a scope trace averaged over many steps
PULSE_REL_NOISE = 1.1e-3
#: shots per point (sequence and wait) of one Ramsey and spin-echo scan of the menu
RAMSEY_SHOTS = 200
#: shots per wait and sideband of one sideband thermometry of the menu
THERMOMETRY_SHOTS = 200


# ----------------------------------------------------------------- items
@dataclass(frozen=True)
class Item:
    """One recording of the menu.

    ``source`` names the hypotheses' prediction it reads (:meth:`Hypothesis.raw`),
    ``select(raw)`` its predicted values from it, ``noise(raw_a, raw_b)`` the whitening
    of its noise at a pair of hypotheses: a vector (independent errors: 1/sigma, 0
    where unusable) or a matrix ``W`` with ``W Cov W^T = I``.  Repeats of the item are
    independent recordings of the same values (their own noise and power errors), unless
    ``pooled(raw_a, raw_b, k)`` gives the whitening of ``k`` repeats pooled with what is
    recorded (a gate setting's scans share its rate error: :mod:`~dpdfit.analyses.diagnosis.proposal.pooled_scans`)."""

    what: str
    settings: dict
    seconds: float
    source: str
    select: Callable
    noise: Callable
    pooled: Callable | None = None

    def vector(self, h: Hypothesis, p: dict | None = None) -> np.ndarray:
        """The item's predicted values under hypothesis ``h`` at ``p`` (default its fit)."""
        return np.asarray(self.select(h.raw(self.source, p)), dtype=float)

    def whitener(self, ha: Hypothesis, hb: Hypothesis, k=None):
        """The whitening of the item's noise at the pair ``(ha, hb)`` (with ``k``: of
        ``k`` repeats pooled with what is recorded; None when repeats are independent)."""
        if k is not None:
            return None if self.pooled is None else self.pooled(
                ha.raw(self.source), hb.raw(self.source), k)
        return self.noise(ha.raw(self.source), hb.raw(self.source))


def white(W, v: np.ndarray) -> np.ndarray:
    """``W v`` for a whitening vector or matrix (non-finite entries as 0)."""
    v = np.asarray(v, dtype=float)
    out = W * v if np.ndim(W) == 1 else np.asarray(W) @ v
    return np.where(np.isfinite(out), out, 0.0)


def _inv_sd(sd) -> np.ndarray:
    sd = np.asarray(sd, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        w = 1.0 / sd
    return np.where(np.isfinite(w) & (sd > 0), w, 0.0)


# ----------------------------------------------------------------- calibration runs
def _amplitude_run(prob, hyps, lab):
    modes = getattr(getattr(prob, "tone", None), "drift_modes", None)
    if modes is None or len(modes) == 0:
        return []
    ra = prob.runs_after
    sd = np.asarray(ra.sd, float) if ra is not None else np.ones(len(modes))
    w = _inv_sd(sd)
    return [Item("amplitude_run", {"runs": 1}, lab.amplitude_run_s, "drift",
                 lambda r: r, lambda a, b: w)]


def _phase_run(prob, hyps, lab):
    """One phase calibration run now, after the recordings: the phase the hypotheses'
    phase transfers predict at the model's run's amplitudes (``A >= PHASE_MIN_A``,
    :func:`~dpdfit.analyses.diagnosis.proposal.hypotheses.phase_run_amplitudes`), with
    that run's errors (as recorded or learnt, else
    :data:`~dpdfit.core.defaults.PHASE_RUN_NOISE_RAD`) and the runs' run-to-run drift of
    ``phi``, as the diagnosis fits such a run
    (:mod:`~dpdfit.analyses.diagnosis.model.phase_runs_block`).  Offered only when a
    further run enters that fit: the campaign has a phase calibration with errors and
    recording times (a run taken after them is data; before these were fitted, every
    phase run the closed loop took achieved a separation of exactly 0).  It separates
    hypotheses that differ in the AOM's own phase transfer (the modulator's AM-to-PM
    left out of the model), not a phase after the AOM."""
    camp = getattr(prob, "camp", None)
    if getattr(prob, "tone", None) is None or camp is None or camp.phase is None \
            or not camp.recorded or camp.phase.sigma_source != "given":
        return []
    A = phase_run_amplitudes(prob)
    pts = camp.phase_points
    sd = (pts[1] if pts is not None and pts[1] is not None
          else np.full(A.size, PHASE_RUN_NOISE_RAD))
    after = camp.phase_runs_after
    drift = after.drift_sd if after is not None else PHASE_RUN_NOISE_RAD
    W = phase_whitener(sd, drift_shape(camp.phase, A), drift)
    return [Item("phase_run", {"runs": 1}, lab.phase_run_s, "phase",
                 lambda r: r, lambda a, b: W)]


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


def _feature_values(P, A, idx) -> np.ndarray:
    """The per-trace features but ``gate_power`` (the absolute scale, a profiled
    nuisance) of the spectra at grid indices ``idx``, flattened."""
    f = tone_features(P[idx], A[idx])
    return np.concatenate([np.ravel(v) for name, (v, _) in f.items() if name != "gate_power"])


def _feature_whitener(prob, idx):
    A = SPECTRA_GRID

    def noise(Pa, Pb):
        P = (Pa[idx] + Pb[idx]) / 2
        f = tone_features(P, A[idx], _tone_sd(prob, P))
        return _inv_sd(np.concatenate([np.ravel(e) for name, (_, e) in f.items()
                                       if name != "gate_power"]))
    return noise


def _spectra_contributions(prob, hyps) -> np.ndarray:
    """Delta chi2 of one trace pair (both DPD flags) at each amplitude of
    :data:`SPECTRA_GRID`, first hypothesis against each other, parameters at their
    fits: (n others, n amplitudes).  It chooses the amplitudes of the spectra items."""
    A = SPECTRA_GRID
    P = [h.raw("powers") for h in hyps]
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
        idx = np.array(sorted(chosen))
        amps = [float(a) for a in SPECTRA_GRID[idx]]
        # the tone repeatability each trace is predicted with: the schedule writes it, so
        # that a lab records the traces as the campaign's were (their averaging)
        items.append(Item("spectra", {"amplitudes": amps, "dpd": [0, 1],
                                      "tone_sd_db": float(prob.tone_noise.s_tone_db)},
                          2 * len(amps) * lab.spectrum_trace_s, "powers",
                          lambda P, idx=idx: _feature_values(P, SPECTRA_GRID, idx),
                          _feature_whitener(prob, idx)))
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
    pops = ("F_pop", "imb") if prob.camp.has_imbalance else ("F_pop",)
    items = []
    for i, (A, d) in enumerate(g.keys):
        # what the setting has: its scans pool with the new ones (module pooled_scans)
        had = dict(ns=float(g.gates["n_scans"].iloc[i]), n_pop=float(g.gates["shots"].iloc[i]),
                   vj=g.sig_jit ** 2, vx=g.rate_error_db((A, d)) ** 2)
        items.append(Item("populations", {"A": float(A), "dpd": int(d), "shots": N},
                          N * lab.shot_s, "gates",
                          lambda pr, i=i: [pr[q][i] for q in pops],
                          scan_whitener(pops, i, N, v_lin, v_quad),
                          pooled_whitener(pops, i, N, n_par, **had)))
        items.append(Item("parity", {"A": float(A), "dpd": int(d), "shots": n_par},
                          n_par * lab.shot_s, "gates",
                          lambda pr, i=i: [pr["C"][i]],
                          scan_whitener(("C",), i, n_par, v_lin, v_quad),
                          pooled_whitener(("C",), i, N, n_par, **had)))
    return items


def _time_scans(prob, hyps, lab):
    if getattr(prob, "gate", None) is None or getattr(prob, "ts", None) is None \
            or not prob.gate.ts_keys:
        return []
    if any("P00_t" not in h.raw("gates") for h in hyps):
        return []
    ts = prob.ts
    # one time scan's shots per point: a point pooled from repeated scans sums theirs
    reps = ts["n_repeats"].to_numpy(float) if "n_repeats" in ts.columns else 1.0
    N = int(np.round(np.median(ts["shots"].to_numpy(float) / reps)))
    items = []
    for A, d in prob.gate.ts_keys:
        sel = (np.isclose(ts["A"].to_numpy(float), A) & (ts["dpd"].to_numpy() == d))

        def select(pr, sel=sel):
            return np.concatenate([pr["P00_t"][sel], pr["P11_t"][sel]])

        def noise(pa, pb, select=select):
            pm = np.clip((select(pa) + select(pb)) / 2, 0.5 / N, 1 - 0.5 / N)
            return _inv_sd(np.sqrt(pm * (1 - pm) / N))

        points = int(sel.sum())
        items.append(Item("time_scan", {"A": float(A), "dpd": int(d), "shots": N,
                                        "points": points},
                          points * N * lab.shot_s, "gates", select, noise))
    return items


# ----------------------------------------------------------------- characterisation
def _spam_whitener(N: int):
    """Whitening of the detected ``P00, P11`` of each prepared state (multinomial of ``N``
    shots, the pair's mean probabilities of the three outcomes each floored at half a
    count, so that the covariance is regular): one 2 x 2 block each."""
    def noise(ra, rb):
        p = np.maximum((np.asarray(ra, float) + np.asarray(rb, float)) / 2, 0.5 / N)
        p = p / p.sum(axis=1, keepdims=True)
        W = np.zeros((2 * len(p),) * 2)
        for i, (p00, _, p11) in enumerate(p):
            C = np.array([[p00 * (1 - p00), -p00 * p11], [-p00 * p11, p11 * (1 - p11)]]) / N
            W[2 * i:2 * i + 2, 2 * i:2 * i + 2] = np.linalg.inv(np.linalg.cholesky(C))
        return W
    return noise


def _spam(prob, hyps, lab):
    """The SPAM characterisation (``spam.csv``): each of
    :data:`~dpdfit.analyses.diagnosis.proposal.hypotheses.SPAM_STATES` prepared and
    detected with no gate,
    :data:`~dpdfit.analyses.diagnosis.proposal.menu.SPAM_SHOTS` shots each; offered with
    gate recordings, whose preparation and detection errors it measures directly (a SPAM
    offset acts on it, dephasing and heating do not)."""
    if getattr(prob, "gate", None) is None or prob.gate.gates is None \
            or len(prob.gate.gates) == 0 or not hasattr(prob.gate, "preparation"):
        return []           # (a gate model without preparation errors cannot predict it)
    N = SPAM_SHOTS
    return [Item("spam", {"shots": N, "states": list(SPAM_STATES)},
                 len(SPAM_STATES) * N * lab.spam_shot_s, "spam",
                 lambda r: np.asarray(r, float)[:, [0, 2]].ravel(), _spam_whitener(N))]


def pulse_relative_noise(camp) -> float:
    """Relative noise of one sample of a further pulse response: the campaign's own
    trace's (the median of ``sigma / power`` over its second half, where it has settled),
    else :data:`PULSE_REL_NOISE`."""
    pulse = getattr(camp, "pulse_response", None)
    if pulse is None:
        return PULSE_REL_NOISE
    late = pulse["t_us"].to_numpy(float) >= 0.5 * float(pulse["t_us"].max())
    power = pulse["power"].to_numpy(float)[late]
    ok = power > 0
    rel = pulse["sigma"].to_numpy(float)[late][ok] / power[ok]
    return float(np.median(rel)) if rel.size else PULSE_REL_NOISE


def _pulse_response(prob, hyps, lab):
    """The AOM pulse response (``pulse_response.csv``): one trace of a step to
    :func:`~dpdfit.analyses.diagnosis.proposal.hypotheses.pulse_amplitude`, normalised to
    its settled level, each sample with :func:`pulse_relative_noise`; offered with the
    spectra, whose model predicts it (only a memory of the modulator changes it)."""
    if getattr(prob, "tone", None) is None:
        return []
    A = pulse_amplitude(prob.camp)
    w = 1.0 / pulse_relative_noise(prob.camp)
    return [Item("pulse_response", {"A": A}, lab.pulse_trace_s, "pulse",
                 lambda r: r, lambda a, b: np.full(np.size(a), w))]


def ramsey_seconds(T2: float, shots: int, lab, points: int = SCAN_POINTS) -> float:
    """Lab time (s) of one Ramsey and spin-echo scan for a coherence time ``T2`` (s): every
    shot of both sequences at every wait of :func:`~dpdfit.models.ramsey.scan_waits` takes
    ``lab.ramsey_shot_s`` plus its wait, every point ``lab.ramsey_point_s``."""
    t = scan_waits(T2, points)
    per_sequence = shots * float(np.sum(lab.ramsey_shot_s + t)) + t.size * lab.ramsey_point_s
    return len(SEQUENCES) * per_sequence


def _ramsey(prob, hyps, lab):
    """The Ramsey and spin-echo characterisation (``ramsey.csv``): both sequences at the
    waits of :func:`~dpdfit.models.ramsey.scan_waits` (to 1.5 times the stated T2),
    :data:`~dpdfit.analyses.diagnosis.proposal.menu.RAMSEY_SHOTS` shots each; offered with
    gate recordings: it measures the coherence time the gate model takes and tells
    common, slow and white dephasing apart (a SPAM offset moves it too, heating does
    not)."""
    if getattr(prob, "gate", None) is None or prob.gate.gates is None \
            or len(prob.gate.gates) == 0 or not hasattr(prob.gate, "preparation"):
        return []
    N, T2 = RAMSEY_SHOTS, float(prob.gate.nominal["T2"])
    t = scan_waits(T2)
    st = {"shots": N, "points": int(t.size), "max_wait_us": round(float(t[-1]) * 1e6, 3)}
    return [Item("ramsey", st, ramsey_seconds(T2, N, lab), "ramsey",
                 lambda r: np.asarray(r, float)[:, [0, 2]].ravel(), _spam_whitener(N))]


def _detector_linearity(prob, hyps, lab):
    """The detector linearity characterisation (``detector_linearity.csv``): the
    calibration photodiode read at each of
    :data:`~dpdfit.analyses.diagnosis.proposal.hypotheses.LINEARITY_DRIVES` without and
    with a calibrated attenuator; a nonlinear photodiode changes the readings' ratio, an
    AOM that moved (a stale table) does not.  Each pair's noise: the calibration runs'
    photodiode noise at both readings
    (:func:`~dpdfit.analyses.diagnosis.observables.detector_linearity.campaign_power_noise`).
    Lab time: every drive read twice, the attenuator put in once
    (:class:`~dpdfit.core.defaults.LabTimes`)."""
    tone = getattr(prob, "tone", None)
    sigma = campaign_power_noise(prob.camp) if tone is not None else None
    if sigma is None:
        return []
    P = linearity_readings(prob)
    n = len(LINEARITY_DRIVES)

    def noise(ra, rb):
        pa = np.maximum((np.asarray(ra, float) + np.asarray(rb, float)) / 2, 0.0)
        return _inv_sd(np.sqrt(sigma(pa) ** 2 + (pa / np.maximum(P, 1e-300) * sigma(P)) ** 2))

    return [Item("detector_linearity", {"points": n, "attenuation_db": LINEARITY_ATTENUATION_DB},
                 lab.attenuator_swap_s + 2 * n * lab.linearity_reading_s, "linearity",
                 lambda r: np.asarray(r, float), noise)]


def _thermometry(prob, hyps, lab):
    """The sideband thermometry (``thermometry.csv``): each wait of
    :data:`~dpdfit.models.sideband_thermometry.THERMOMETRY_WAITS_US` probed on the red and
    the blue sideband,
    :data:`~dpdfit.analyses.diagnosis.proposal.menu.THERMOMETRY_SHOTS` shots each
    (binomial bright counts); its lab time the shots' own and their waits.  Offered with
    gate recordings, whose mode's occupation and heating rate it measures directly
    (heating acts on it, dephasing does not)."""
    if getattr(prob, "gate", None) is None or prob.gate.gates is None \
            or len(prob.gate.gates) == 0 or not hasattr(prob.gate, "preparation"):
        return []
    N = THERMOMETRY_SHOTS
    waits = np.asarray(THERMOMETRY_WAITS_US, float)
    seconds = N * len(SIDEBANDS) * float(np.sum(lab.thermometry_shot_s + waits * 1e-6))

    def noise(pa, pb):
        pm = np.clip((np.asarray(pa, float) + np.asarray(pb, float)) / 2, 0.5 / N, 1 - 0.5 / N)
        return _inv_sd(np.sqrt(pm * (1 - pm) / N))

    return [Item("thermometry", {"shots": N, "waits_us": waits.tolist(),
                                 "sidebands": list(SIDEBANDS)},
                 seconds, "thermometry", lambda r: np.asarray(r, float), noise)]


#: the builders of the menu, in the order the menu lists them
BUILDERS = (_amplitude_run, _phase_run, _spectra, _gate_scans, _time_scans, _spam,
            _pulse_response, _ramsey, _detector_linearity, _thermometry)
