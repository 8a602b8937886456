"""The Ramsey and spin-echo characterisation (``ramsey.csv``) as data of every hypothesis,
and the coherence time it records beside the lab's stated one.

With ``ramsey.csv`` the recorded decays are data of every hypothesis: the catalog's
dephasing (any form: white or slow, independent or common) is measured in free precession
as well as through the gates.  The null model reports the coherence time the recording
measures on its own (:func:`recorded_t2`) beside the lab's stated ``T2`` (``error_model``
``T2_s``).  That T2 is not made a free nuisance of the baseline: a white independent
dephasing would then be taken up by it, and a coherence shorter than stated -- what the
catalog's ``dephasing`` names -- would never be named.  :class:`RecordedCoherence`
carries a coherence time :data:`T2_REC` into the gates (through the independent
dephasing knob) for a caller that sets one.  Without the file nothing changes: no block,
no report.

The prediction (:func:`ramsey_block`, physics in :mod:`dpdfit.models.ramsey`): each
ion's accumulated dephasing over the wait ``t`` is ``t / T2`` (the stated one, white and
independent: the echo keeps it) plus what each effect adds in free precession
(:meth:`~dpdfit.analyses.diagnosis.effects.base.Effect.free_dephasing`: dephasing's
common, slow and stretched parts, the echo removing the slow ones); the preparation and
detection errors are the gate model's own
(:meth:`~dpdfit.analyses.diagnosis.model.gates.gate_model.GateModel.preparation`), so a
SPAM offset moves it too, heating does not.  The counts of a point are multinomial over
``n00, n01_10, n11``; the residuals are their signed deviance residuals
(:func:`~dpdfit.analyses.diagnosis.model.spam_block.deviance_residuals`).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq, minimize_scalar

from dpdfit.analyses.diagnosis.effects.dephasing import INDEPENDENT
from dpdfit.analyses.diagnosis.model.gates.effect_terms import active_effects
from dpdfit.analyses.diagnosis.model.spam_block import deviance_residuals
from dpdfit.models.ramsey import ramsey_probabilities

__all__ = ["T2_REC", "OUTCOMES", "RecordedCoherence", "RECORDED_COHERENCE",
           "recorded_coherence", "t2_rec_prior", "ramsey_probabilities_of", "ramsey_block",
           "coherence_report", "recorded_t2"]

#: the baseline's nuisance with ramsey.csv: the recorded coherence time (ms)
T2_REC = "T2_rec"
#: the detected outcomes of a row, in order (``ramsey.csv``'s count columns)
OUTCOMES = ("n00", "n01_10", "n11")
#: the flat prior's bounds, as multiples of the stated T2: a Ramsey scan to ~1.5 T2
#: resolves coherence times from a few percent of it to several times it
_BOUNDS = (0.02, 10.0)


class RecordedCoherence:
    """The recorded coherence time in the gate model's terms: the hooks of an effect
    (:class:`~dpdfit.analyses.diagnosis.effects.base.Effect`) that the gate model's
    prediction reads, so it joins the active effects (:func:`recorded_coherence`).  Its
    one value ``rate`` is ``1/T2_rec - 1/T2_stated`` (1/s), the weight of the independent
    dephasing knob at every time."""

    name = T2_REC

    def knob_coefficients(self, gm, v: dict, t) -> dict:
        """The independent dephasing knob at the rate ``v["rate"]`` at every time."""
        return {INDEPENDENT.key: np.full(np.shape(t), float(v["rate"]))}

    def power_offset_db(self, gm, v: dict, A) -> np.ndarray:
        """No power offset."""
        return np.zeros(np.shape(A))

    def coherence(self, gm, v: dict, t):
        """No decay of the final coherences beyond the engine's."""
        return None

    def preparation(self, gm, v: dict, prep):
        """The preparation and detection errors unchanged."""
        return prep


#: the one instance the gate model uses
RECORDED_COHERENCE = RecordedCoherence()


def t2_rec_prior(stated_T2_s: float) -> tuple:
    """``(centre, bounds)`` of :data:`T2_REC` (ms): the lab's stated value, flat within
    :data:`_BOUNDS` of it."""
    c = float(stated_T2_s) * 1e3
    return c, (c * _BOUNDS[0], c * _BOUNDS[1])


def recorded_coherence(gm, p: dict) -> list:
    """``[(RECORDED_COHERENCE, {"rate": ...})]`` when ``p`` holds :data:`T2_REC` and the
    gate model ``gm`` has the independent dephasing knob, else ``[]`` (the prediction
    exactly as without ``ramsey.csv``)."""
    T2 = p.get(T2_REC)
    if T2 is None or INDEPENDENT.key not in gm.knobs:
        return []
    rate = 1.0 / (max(float(T2), 1e-9) * 1e-3) - 1.0 / float(gm.nominal["T2"])
    return [(RECORDED_COHERENCE, {"rate": rate})]


def ramsey_probabilities_of(gm, p: dict, active: list, t, echo: bool) -> np.ndarray:
    """``(len(t), 3)`` detected outcomes of one sequence at the waits ``t`` (s) under
    parameters ``p`` (``active``: the effects present, with their values; without
    :data:`T2_REC` in ``p``, a campaign without ``ramsey.csv``, the stated T2), the
    effects' free-precession dephasing
    (:meth:`~dpdfit.analyses.diagnosis.effects.base.Effect.free_dephasing`) added."""
    t = np.asarray(t, dtype=float)
    T2 = float(p.get(T2_REC, gm.nominal["T2"] * 1e3)) * 1e-3
    G_i = t / max(T2, 1e-12)
    G_c = np.zeros(t.shape)
    for e, v in active:
        g = e.free_dephasing(gm, v, t, echo)
        if g is not None:
            G_i, G_c = G_i + g[0], G_c + g[1]
    prep = gm.preparation(p, active)
    return ramsey_probabilities(G_i, G_c, prep.spectator, prep.flip, prep.e01, prep.e10)


def ramsey_block(ctx, p: dict) -> tuple:
    """``(label, z)``: the deviance residuals of ``ctx.camp.ramsey`` (one row per point,
    its three outcomes) at the parameter set ``p``."""
    df = ctx.camp.ramsey
    gm = ctx.gate
    active = active_effects(gm.effects, p)
    probs = np.zeros((len(df), 3))
    seq = df["sequence"].to_numpy()
    t = df["wait_s"].to_numpy(dtype=float)
    for s in ("ramsey", "echo"):
        sel = seq == s
        if sel.any():
            probs[sel] = ramsey_probabilities_of(gm, p, active, t[sel], s == "echo")
    z = deviance_residuals(df[list(OUTCOMES)].to_numpy(float), df["shots"].to_numpy(float),
                           probs)
    return {"kind": "ramsey", "observable": "ramsey"}, z.ravel()


def coherence_report(prob, base=None) -> dict:
    """The null model's ``coherence``: the lab's stated T2 (ms) and, once the baseline
    ``base`` is fitted, the T2 the Ramsey and echo recording measures on its own
    (:func:`recorded_t2`) with its 1-sigma error."""
    out = {"T2_stated_ms": float(prob.gate.nominal["T2"]) * 1e3, "source": "ramsey.csv"}
    if base is not None:
        out.update(recorded_t2(prob, base.all_params))
    return out


def recorded_t2(prob, p: dict) -> dict:
    """The white independent coherence time the Ramsey and echo recording measures (ms):
    the block's deviance minimised over :data:`T2_REC` alone, the other parameters at
    ``p`` (the baseline's), its error where the deviance has risen by 1 (the profile
    likelihood).  Reported, not fitted with the gates: the stated T2 stays the baseline's,
    so that a shorter recorded one is named as the catalog's extra dephasing, with the
    gates' evidence, rather than taken up by the baseline (``T2_recorded_err_ms`` NaN
    when the recording does not bound it within :data:`_BOUNDS` of the stated T2)."""
    stated = float(prob.gate.nominal["T2"]) * 1e3
    lo, hi = np.log(stated * _BOUNDS[0]), np.log(stated * _BOUNDS[1])

    def dev(x):
        return float(np.sum(np.square(ramsey_block(prob, {**p, T2_REC: np.exp(x)})[1])))
    res = minimize_scalar(dev, bounds=(lo, hi), method="bounded",
                          options={"xatol": 1e-6})
    best, d0 = float(res.x), float(res.fun)
    errs = []
    for side, edge in ((-1.0, lo), (1.0, hi)):
        if dev(edge) < d0 + 1.0:
            errs.append(float("nan"))
            continue
        x = brentq(lambda x: dev(x) - d0 - 1.0, *sorted((best, edge)))
        errs.append(abs(np.exp(x) - np.exp(best)))
    return {"T2_recorded_ms": float(np.exp(best)), "T2_recorded_err_ms": float(np.mean(errs))}
