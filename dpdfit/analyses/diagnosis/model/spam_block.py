"""The SPAM characterisation (``spam.csv``) as data of every hypothesis: each basis state
prepared and detected with no gate.

Its prediction is the gate model's own preparation and detection errors
(:meth:`~dpdfit.analyses.diagnosis.model.gates.gate_model.GateModel.preparation`: the
nuisances ``prep_split``, ``e01``, ``e10`` and every effect's
:meth:`~dpdfit.analyses.diagnosis.effects.base.Effect.preparation`), so an effect that
changes the preparation (a SPAM offset) is constrained by it and one that acts during the
gate (dephasing, heating) is not.  Per ion: a spectator (a level outside the qubit,
driven by no pulse) reads bright ``0``; a flipped ion is in the other qubit state; a
``1`` is prepared from ``0`` by a pi pulse.  A prepared ``0`` reads dark with probability
``flip (1 - e10) + (1 - flip) e01``, a prepared ``1`` with ``(1 - spectator - flip)
(1 - e10) + (spectator + flip) e01`` (:func:`spam_probabilities`).

The counts of a prepared state are multinomial over ``n00, n01_10, n11``; its residuals
are the signed deviance residuals (:func:`deviance_residuals`): their squares sum to the
multinomial ``-2 ln`` likelihood ratio against the saturated model, exact for the rare
outcomes a SPAM recording is made of (a single count where ``1e-3`` is expected is 3.4,
not the 31 of a Pearson residual).
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.effects import Prep

__all__ = ["spam_probabilities", "deviance_residuals", "spam_block", "OUTCOMES"]

#: the detected outcomes of a row, in order (``spam.csv``'s count columns)
OUTCOMES = ("n00", "n01_10", "n11")


def spam_probabilities(prep: Prep, prepared) -> np.ndarray:
    """``(len(prepared), 3)``: detected ``P00, P01_10, P11`` of each prepared basis state
    (``"00"``, ``"01"``, ``"10"``, ``"11"``) under the errors ``prep`` (module doc)."""
    e01, e10 = float(prep.e01), float(prep.e10)
    q, f = float(prep.spectator), float(prep.flip)
    dark = {"0": f * (1 - e10) + (1 - f) * e01,
            "1": (1 - q - f) * (1 - e10) + (q + f) * e01}
    a = np.array([dark[s[0]] for s in prepared], dtype=float)
    b = np.array([dark[s[1]] for s in prepared], dtype=float)
    return np.stack([(1 - a) * (1 - b), a * (1 - b) + (1 - a) * b, a * b], axis=-1)


def deviance_residuals(counts, shots, probs) -> np.ndarray:
    """Signed deviance residuals of multinomial ``counts`` (rows of outcomes) of ``shots``
    at the probabilities ``probs``: ``sign(n - mu) sqrt(2 (n ln(n / mu) - (n - mu)))``,
    ``mu = shots p`` (probabilities floored at 1e-300: a count where the model allows
    none is far off, not infinite)."""
    n = np.asarray(counts, dtype=float)
    mu = np.asarray(shots, dtype=float)[:, None] * np.maximum(probs, 1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):
        log_term = np.where(n > 0, n * np.log(n / mu), 0.0)
    d = np.maximum(2.0 * (log_term - (n - mu)), 0.0)
    return np.sign(n - mu) * np.sqrt(d)


def spam_block(ctx, p: dict) -> tuple:
    """``(label, z)``: the deviance residuals of ``ctx.camp.spam`` (one row per prepared
    state, its three outcomes) at the parameter set ``p``, the preparation and detection
    errors the gate model ``ctx.gate`` gives there."""
    spam = ctx.camp.spam
    probs = spam_probabilities(ctx.gate.preparation(p), spam["prepared"].tolist())
    z = deviance_residuals(spam[list(OUTCOMES)].to_numpy(float),
                           spam["shots"].to_numpy(float), probs)
    return {"kind": "spam", "observable": "spam"}, z.ravel()
