"""What further scans of a recorded gate setting add: pooled with its scans so far.

The diagnosis reads a gate setting as one pooled observation (its populations summed over
its scans, its contrast averaged over them) whose variance has a part that more scans
average down -- shot noise and each scan's own laser-power jitter -- and a part they do
not: the setting's gate-rate calibration error, shared by all its scans
(:class:`~dpdfit.analyses.diagnosis.model.gates.gate_model.GateModel`).  ``k`` further scans of the
setting therefore add the information

    ``Q_k = S(n + k)^-1 - S(n)^-1``,

``S(n)`` the pooled observation's covariance after ``n`` scans, and not ``k`` times that
of one scan: once the shared error dominates, more scans separate nothing more.  Treating
the repeats as independent predicted a separation of about 40 for 260 population scans
where the closed loop measured less than 5.  :func:`pooled_whitener` gives ``W_k`` with
``W_k^T W_k = Q_k``, what :class:`~dpdfit.analyses.diagnosis.proposal.expected_separation.Direction` uses
for an item's ``k`` repeats.
"""

from __future__ import annotations

import numpy as np

__all__ = ["pooled_whitener", "scan_whitener"]


def _covariance(qs, mean, g, h, ns: float, n_pop: float, n_par: float, vj: float,
                vx: float) -> np.ndarray:
    """Covariance of the pooled observation ``qs`` after ``ns`` scans of ``n_pop``
    population shots in all and ``n_par`` parity shots each."""
    F = float(np.clip(mean["F_pop"], 0.5 / n_pop, 1 - 0.5 / n_pop))
    imb = float(np.clip(mean["imb"], -F, F)) if np.isfinite(mean["imb"]) else 0.0
    C = float(np.clip(mean["C"], -1.0, 1.0))
    shot = {("F_pop", "F_pop"): F * (1 - F) / n_pop, ("imb", "imb"): (F - imb ** 2) / n_pop,
            ("F_pop", "imb"): imb * (1 - F) / n_pop, ("imb", "F_pop"): imb * (1 - F) / n_pop,
            # the contrast is the mean of the scans' fitted contrasts
            ("C", "C"): 2 * (1 - 0.75 * C ** 2) / (n_par * ns)}
    S = np.array([[shot.get((a, b), 0.0) for b in qs] for a in qs])
    return (S + (vj / ns + vx) * np.outer(g, g)
            + 2 * (vj ** 2 / ns + vx ** 2) * np.outer(h, h))


def pooled_whitener(qs: tuple, i: int, shots: float, n_par: float, ns: float, n_pop: float,
                    vj: float, vx: float):
    """``noise(raw_a, raw_b, k)``: the whitening ``W_k`` (``W_k^T W_k = Q_k``, module doc)
    of ``k`` further scans observing ``qs`` at gate setting ``i``, each of ``shots``
    population shots (or ``n_par`` parity shots over its phases), the setting having
    ``ns`` scans of ``n_pop`` population shots in all, per-scan power jitter variance
    ``vj`` and a rate-calibration variance ``vx`` (dB^2), at the pair's mean prediction."""
    par_shots = float(n_par)
    old_pop = max(float(n_pop), 1.0)

    def noise(pa, pb, k):
        mean = {q: (pa[q][i] + pb[q][i]) / 2 if q in pa else np.nan
                for q in ("F_pop", "imb", "C")}
        g = np.array([(pa["dlin_" + q][i] + pb["dlin_" + q][i]) / 2 for q in qs])
        h = np.array([(pa["dquad_" + q][i] + pb["dquad_" + q][i]) / 2 for q in qs])
        new_pop = old_pop + (float(k) * shots if "C" not in qs else 0.0)
        S0 = _covariance(qs, mean, g, h, ns, old_pop, par_shots, vj, vx)
        S1 = _covariance(qs, mean, g, h, ns + float(k), new_pop, par_shots, vj, vx)
        if not (np.all(np.isfinite(S0)) and np.all(np.isfinite(S1))):
            return np.zeros((1, len(qs)))
        Q = np.linalg.inv(S1) - np.linalg.inv(S0)
        lam, V = np.linalg.eigh(0.5 * (Q + Q.T))
        return np.sqrt(np.clip(lam, 0.0, None))[:, None] * V.T
    return noise


def scan_whitener(qs: tuple, i: int, N: float, v_lin: float, v_quad: float):
    """Whitening of one new scan of ``N`` shots observing ``qs`` at setting ``i``: shot
    noise at the pair's mean plus the scan's shared random power error."""
    def noise(pa, pb):
        mean = {q: (pa[q][i] + pb[q][i]) / 2 for q in ("F_pop", "imb", "C")}
        F = np.clip(mean["F_pop"], 0.5 / N, 1 - 0.5 / N)
        imb = np.clip(mean["imb"], -F, F)
        C = np.clip(mean["C"], -1.0, 1.0)
        shot = {("F_pop", "F_pop"): F * (1 - F), ("imb", "imb"): F - imb ** 2,
                ("F_pop", "imb"): imb * (1 - F), ("imb", "F_pop"): imb * (1 - F),
                ("C", "C"): 2 * (1 - 0.75 * C ** 2)}
        g = np.array([(pa["dlin_" + q][i] + pb["dlin_" + q][i]) / 2 for q in qs])
        h = np.array([(pa["dquad_" + q][i] + pb["dquad_" + q][i]) / 2 for q in qs])
        cov = (np.array([[shot[(a, b)] / N for b in qs] for a in qs])
               + v_lin * np.outer(g, g) + v_quad * np.outer(h, h))
        if not np.all(np.isfinite(cov)):
            return np.zeros(len(qs))
        # W with W cov W^T = I from the eigenvalues (a pair predicting P00 or P11 at zero
        # makes the population covariance singular); a null direction carries nothing
        lam, V = np.linalg.eigh(0.5 * (cov + cov.T))
        keep = lam > 1e-12 * max(float(lam.max()), 0.0)
        return (V[:, keep] / np.sqrt(lam[keep])).T
    return noise
