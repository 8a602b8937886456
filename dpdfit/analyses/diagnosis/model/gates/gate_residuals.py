"""The standardised residuals of the gate side: each setting's gate observables (whitened
together, :mod:`~dpdfit.analyses.diagnosis.model.gates.whitening`) and the time scans'
populations, against a gate model's prediction (:class:`GateResiduals`)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from dpdfit.analyses.diagnosis.model.gates.gate_model import GateModel
from dpdfit.analyses.diagnosis.model.gates.whitening import whiten_stacked

__all__ = ["GateResiduals", "scan_points"]


def scan_points(ts: pd.DataFrame) -> pd.DataFrame:
    """The time scans' points after the start (``t > 0``), grouped by setting."""
    parts = []
    for (A, d), t in ts.groupby(["A", "dpd"], sort=False):
        parts.append(t[t.t_s > 0])
    return pd.concat(parts, ignore_index=True)


class GateResiduals:
    """The recorded gate observables of a campaign and their residuals against a gate
    model.

    Attributes
    ----------
    observables : tuple
        The gate observables recorded (of ``F_pop``, ``imb``, ``C``).
    measured, shot : dict
        Per observable, the values over the settings and their shot-noise errors.
    ts : pandas.DataFrame or None
        The time scans' points after the start (:func:`scan_points`).
    """

    def __init__(self, gates: pd.DataFrame, time_scans: pd.DataFrame | None):
        self.observables = tuple(q for q in ("F_pop", "imb", "C")
                                 if np.isfinite(gates[q]).any())
        self.measured = {q: gates[q].to_numpy() for q in self.observables}
        self.shot = {q: gates[q + "_shot"].to_numpy() for q in self.observables}
        self.ts = None if time_scans is None else scan_points(time_scans)
        # what no parameter moves, made once: a fit evaluates the residuals thousands of
        # times, and a column of a DataFrame costs more than the arithmetic on it
        self._measured = np.stack([self.measured[q] for q in self.observables], axis=1)
        self._shot = np.stack([self.shot[q] for q in self.observables], axis=1)
        self._scan = None
        if self.ts is not None:
            N = self.ts["shots"].to_numpy(dtype=float)
            self._scan = (N, 0.5 / N, 1 - 0.5 / N,
                          {"P00_t": self.ts["n00"].to_numpy() / N,
                           "P11_t": self.ts["n11"].to_numpy() / N})
        self._key, self._val = None, None

    def whitened(self, gate: GateModel, p: dict, logdet: bool = False):
        """Whitened gate residuals of the gate model ``gate`` at ``p``
        (:func:`~dpdfit.analyses.diagnosis.model.gates.whitening.whiten_prediction`; with
        ``logdet``, also the log-determinant of their covariance)."""
        return whiten_stacked(self._measured, self._shot, gate.predict(p), self.observables,
                              logdet)

    def gate_blocks(self, gate: GateModel, p: dict, whiten: bool) -> list:
        """``[(label, z)]`` of the gate observables and the time scans at the gate-side
        parameters ``p`` of the gate model ``gate``.

        With ``whiten`` (the fits) the gate observables of one setting, which share its
        random power errors, are decorrelated (``F_pop`` standardised, ``imb`` given
        ``F_pop``, ``C`` given both), so their chi2 counts the shared error once; without
        it (the deviation search, plots) each is standardised on its own.  Cached on the
        parameters: a tone-side fit holds them, and then the gate residuals are the same
        at every one of its evaluations.
        """
        key = (id(gate), id(gate.base), getattr(gate, "rate_rel", None), gate.resp is None,
               whiten, tuple(sorted((k, float(v)) for k, v in p.items())))
        if self._key == key:
            return list(self._val)
        pr = gate.predict(p)
        qs = self.observables
        if whiten:
            z = whiten_stacked(self._measured, self._shot, pr, qs)
        else:
            r = np.stack([self.measured[q] - pr[q] for q in qs], axis=1)
            z = r / np.sqrt(np.stack([self.shot[q] ** 2 + pr["var_" + q] for q in qs], axis=1))
        out = [({"kind": "gates", "observable": q}, z[:, j]) for j, q in enumerate(qs)]
        if self._scan is not None and "P00_t" in pr:
            N, lo, hi, frac = self._scan
            for q in ("P00_t", "P11_t"):
                pm = np.clip(pr[q], lo, hi)
                zt = (frac[q] - pr[q]) / np.sqrt(pm * (1 - pm) / N)
                out.append(({"kind": "time_scan", "observable": q}, zt))
        self._key, self._val = key, out
        return list(out)
