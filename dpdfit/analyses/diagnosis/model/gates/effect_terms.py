"""What the gate-side effects present in a parameter set change in a prediction of the
gate model (:meth:`~dpdfit.analyses.diagnosis.model.gates.gate_model.GateModel.predict`).

Each effect acts through its hooks
(:class:`~dpdfit.analyses.diagnosis.effects.base.Effect`): the preparation and detection
errors (:func:`preparation`), the weights of the knobs' responses and the power offsets
at every observation time (:func:`weights`), the decay of the final state's coherences
(:func:`coherence`).  :func:`effect_terms` gathers what the effects' values alone fix in
a prediction, for the gate settings and each time scan, with the knobs' changes of the
two-ion outcomes (:func:`~dpdfit.analyses.diagnosis.model.gates.observe.knob_terms`).
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.effects import EFFECTS, Prep
from dpdfit.analyses.diagnosis.model.gates.observe import knob_terms
from dpdfit.analyses.diagnosis.model.recorded_motion import RECORDED_MOTION, motion_values

__all__ = ["active_effects", "preparation", "coherence", "weights", "effect_terms"]


def active_effects(names, p: dict) -> list:
    """``[(effect, values)]``: the effects of ``names`` present in the parameter set ``p``,
    each with its values by its own parameter names; then the baseline's recorded motional
    state when ``p`` has its nuisances (a campaign with thermometry,
    :mod:`~dpdfit.analyses.diagnosis.model.recorded_motion`)."""
    out = []
    present = {k.partition(".")[0] for k in p if "." in k}     # cheaper than each's values
    for name in names:
        if name not in present:
            continue
        v = EFFECTS[name].values(p)
        if v is not None:
            out.append((EFFECTS[name], v))
    motion = motion_values(p)
    if motion is not None:
        out.append((RECORDED_MOTION, motion))
    return out


def preparation(gm, p: dict, active: list) -> Prep:
    """Preparation and detection errors per ion at parameters ``p`` (the nuisances
    ``prep_split``, ``e01``, ``e10`` around the lab's ``p_prep`` and ``p_det`` of the gate
    model ``gm``, then the ``active`` effects')."""
    # np.clip's values, without its cost on one number (a prediction asks at every call)
    f = min(max(float(p.get("prep_split", 0.5)), 0.0), 1.0)
    prep = Prep(f * gm.p_total, (1 - f) * gm.p_total,
                max(float(p.get("e01", gm.p_det)), 0.0),
                max(float(p.get("e10", gm.p_det)), 0.0))
    for e, v in active:
        prep = e.preparation(gm, v, prep)
    return prep


def coherence(gm, active: list, t):
    """Product of the active effects' coherence factors ``(k1, k2)`` at times ``t``
    (None: no effect decoheres the final state)."""
    out = None
    for e, v in active:
        k = e.coherence(gm, v, t)
        if k is not None:
            out = k if out is None else (out[0] * k[0], out[1] * k[1])
    return out


def weights(gm, active: list, t, A):
    """Knob weights and power offsets of the active effects at times ``t``, amplitudes ``A``."""
    coefs = {}
    eps = np.zeros(np.shape(A))
    for e, v in active:
        for kk, c in e.knob_coefficients(gm, v, t).items():
            coefs[kk] = coefs.get(kk, 0.0) + np.broadcast_to(c, np.shape(t))
        eps = eps + e.power_offset_db(gm, v, A)
    return coefs, eps


def effect_terms(gm, active: list, tab: dict) -> dict:
    """What the active gate-side effects' values alone fix in a prediction of the gate
    model ``gm`` (its response tables ``tab``): the knob weights, power offsets,
    coherence and knob changes of the gates (``"gate"``) and of each time scan
    (``"ts"``)."""
    coefs, eps = weights(gm, active, gm.T_gate, gm.A_settings)
    ts_weights = [weights(gm, active, times, np.full(1, key_t[0]))
                  for key_t, times, _ in tab["ts"]]
    coh = coherence(gm, active, gm.T_gate)
    gate = (coefs, eps, coh, knob_terms(tab["gate"][0], tab["gate"][1], coefs, ("p2", "par2")))
    ts = []
    for (_, _, (b, dd, _, _)), (c_t, e_t) in zip(tab["ts"], ts_weights):
        c_t = {kk: np.asarray(c)[None, :] if np.ndim(c) else c for kk, c in c_t.items()}
        ts.append((c_t, float(e_t[0]), knob_terms(b, dd, c_t, ("p2",))))
    return {"gate": gate, "ts": ts}
