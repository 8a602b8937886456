"""The change of the gate observables with a gate-side effect's knob and with the power,
from engine runs at stepped values."""

from __future__ import annotations

import numpy as np

__all__ = ["KNOB_MULTIPLES", "POWER_STEP_DB", "KnobResponse", "response_tables"]

#: finite-difference step of the power response (dB)
POWER_STEP_DB = 0.3
#: a nonlinear knob is run at these multiples of its step (a linear one at the first):
#: the response between and beyond them follows an exponential (saturating or growing)
#: through both, which is exact for a coherence that decays exponentially with a
#: dephasing rate (:class:`KnobResponse`)
KNOB_MULTIPLES = (1, 3)


class KnobResponse:
    """The change of an observable with a knob's value ``c``, from engine runs at ``s``
    and ``3 s`` (changes ``d1``, ``d3``), element by element:
    ``A (1 - q^(c/s))`` with ``1 + q + q^2 = d3/d1`` -- exact for an exponential
    dependence (a coherence decaying with a dephasing rate), linear for ``q = 1``.
    Where the two runs are not of that shape (``d3/d1`` outside ``(1.05, 8)``, or
    ``d1`` negligible) the quadratic through 0, ``s``, ``3 s`` is used.  Hand-written:
    a per-element interpolation law."""

    def __init__(self, d1, d3=None, s=1.0):
        self.s = float(s)
        if d3 is None:                                   # one run: the linear response
            d3 = 3 * d1
        with np.errstate(divide="ignore", invalid="ignore"):
            r = d3 / d1
        ok = np.isfinite(r) & (r > 1.05) & (r < 8.0) & (np.abs(d1) > 1e-9)
        # 1 + q + q^2 = r  ->  q = (-1 + sqrt(4 r - 3)) / 2
        q = np.where(ok, (-1 + np.sqrt(np.maximum(4 * np.where(ok, r, 3.0) - 3, 0))) / 2, 1.0)
        lin = ok & (np.abs(q - 1) < 1e-6)
        self.exp = ok & ~lin
        self.lnq = np.where(self.exp, np.log(np.where(self.exp, q, 1.0)), 0.0)
        self.amp = np.where(self.exp, d1 / np.where(self.exp, 1 - q, 1.0), 0.0)
        # quadratic elsewhere: d(c) = a (c/s) + b (c/s)^2
        b = (d3 - 3 * d1) / 6
        self.qa = np.where(self.exp, 0.0, d1 - np.where(lin, 0.0, b))
        self.qb = np.where(self.exp | lin, 0.0, b)
        self.any_exp = bool(self.exp.any())

    def __call__(self, c):
        x = np.asarray(c, dtype=float) / self.s
        if not self.any_exp:                 # no exponential element: the quadratic alone
            return self.qa * x + self.qb * x * x
        return (np.where(self.exp, self.amp * (1 - np.exp(np.clip(self.lnq * x, -50, 50))), 0.0)
                + self.qa * x + self.qb * x * x)


def response_tables(base_runs: dict, resp_runs: dict | None, knobs: dict, keys, part: str):
    """Arrays over the settings ``keys`` of the base branch outcomes (``base_runs``) and
    the two-ion responses to every knob and to the power (``resp_runs``; None: zero),
    for the gates (``part="gate"``, the first time) or the time scans (the others)."""
    sel = (lambda a: a[0]) if part == "gate" else (lambda a: a[1:])
    qs = ("p2", "par2") if part == "gate" else ("p2",)

    def get(run, q):
        return sel(run[q]) if q == "p2" else run[q]

    base = {}
    for name in ("p2", "p1", "p2_01", "p1_1"):
        base[name] = np.stack([sel(base_runs[key][name]) for key in keys])
    if part == "gate":
        for name in ("par2", "par1", "par2_01", "par1_1"):
            base[name] = np.stack([base_runs[key][name] for key in keys])
    if resp_runs is None:
        zero = {q: np.zeros_like(base[q]) for q in qs}
        return base, {}, zero, zero
    d = {}
    for kk, knob in knobs.items():
        mults = KNOB_MULTIPLES if knob.nonlinear else KNOB_MULTIPLES[:1]
        d[kk] = {q: KnobResponse(
            *(np.stack([get(resp_runs[key][(kk, m)], q) - get(base_runs[key], q)
                        for key in keys]) for m in mults), s=knob.step)
            for q in qs}
    e = POWER_STEP_DB
    lin, quad = {}, {}
    for q in qs:
        plus = np.stack([get(resp_runs[key]["eps+"], q) for key in keys])
        minus = np.stack([get(resp_runs[key]["eps-"], q) for key in keys])
        lin[q] = (plus - minus) / (2 * e)
        quad[q] = (plus + minus - 2 * base[q]) / (2 * e * e)
    return base, d, lin, quad
