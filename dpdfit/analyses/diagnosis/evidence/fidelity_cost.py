"""The cost in Bell fidelity of a named effect, with its delta-method error."""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.effects import EFFECTS, effect_of_key
from dpdfit.analyses.diagnosis.fitting.fit_result import FitResult
from dpdfit.analyses.diagnosis.observables.tone_features import TONE_HARMONICS
from dpdfit.models.fidelity import estimate

__all__ = ['fidelity_cost']


def _bell_fidelities(prob, p: dict, side: str, amps) -> np.ndarray:
    """Fidelities at the recorded gate settings that an effect of ``side`` changes: the
    predicted Bell fidelity ``(F_pop + C)/2`` (gates), the spectral estimate ``F_est``
    (S5, mean of the sidebands, both DPD flags; tones)."""
    if side == "gates":
        return prob.gate.bell_fidelity(p)
    h = [TONE_HARMONICS.index(n) for n in (0, 1, 2, 3)]
    P = prob.tone.tone_powers_at(amps, p)                # (nA, 2 dpd, 2 sb, H)
    return np.array([[np.mean([estimate(P[i, d, sb][h], (0, 1, 2, 3)).F_est
                               for sb in (0, 1)]) for d in (0, 1)]
                     for i in range(len(amps))]).ravel()


def fidelity_cost(prob, f: FitResult, name: str, with_error: bool = True
                  ) -> tuple[float, float]:
    """The cost in Bell fidelity of effect ``name`` at its fit ``f``: the mean over the
    recorded gate settings of the fidelity without it minus with it, and the 1-sigma
    error by the delta method over its free parameters.

    Gate-side effects: the predicted Bell fidelity ``(F_pop + C)/2``; tone-side
    effects: the spectral estimate ``F_est`` (the gate settings' amplitudes; without
    gate settings the spectra's amplitudes >= 0.2).
    """
    e = EFFECTS[name]
    p1 = f.all_params
    p0 = {k: v for k, v in p1.items() if effect_of_key(k) is not e}
    if e.side == "gates" and prob.gate is None:
        return float("nan"), float("nan")
    amps = (sorted({a for a, _ in prob.gate.keys}) if prob.gate is not None
            else [a for a in prob.camp.A_tones if a >= 0.2])
    F0 = _bell_fidelities(prob, p0, e.side, amps)

    def cost(p):
        return float(np.mean(F0 - _bell_fidelities(prob, p, e.side, amps)))

    c = cost(p1)
    free = [k for k in f.free if effect_of_key(k) is e]
    if not with_error or not free or f.cov is None:
        return c, float("nan")
    idx = [f.free.index(k) for k in free]
    g = np.zeros(len(free))
    for j, k in enumerate(free):
        h = 1e-3 * e.param(k.split(".", 1)[1], prob).scale
        g[j] = (cost({**p1, k: p1[k] + h}) - cost({**p1, k: p1[k] - h})) / (2 * h)
    cov = f.cov[np.ix_(idx, idx)]
    err = float(np.sqrt(max(g @ cov @ g, 0.0))) if np.all(np.isfinite(cov)) else float("nan")
    return c, err
