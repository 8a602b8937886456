"""From the engine's branch outcomes to what a lab measures, for
:meth:`~dpdfit.analyses.diagnosis.model.gates.gate_model.GateModel.predict`.

**Measured probabilities** (:func:`observe`): the two-ion outcomes at a power error and
knob weights (their linear and quadratic power responses and the knobs' responses added
to the base), mixed with the preparation branches and read through the detection errors.
A prediction evaluates them at three power errors; what does not depend on it (the
knobs' changes, the fixed branches' terms of the mixture, the confusion matrix) is made
once (:func:`knob_terms`, :class:`BranchMixer`, :func:`confusion_t`), with the same values
in the same order of sums as :func:`~dpdfit.models.gate_sim.mix_branches` and
:func:`~dpdfit.models.gate_sim.confusion`.

**Fringes** on the analysis phases :data:`PHASES` (:func:`collapse`, :func:`contrast`,
:func:`decohere`): the fringe of a setting is a combination of ``1, cos phi, sin phi,
cos 2phi, sin 2phi``; on 16 equally spaced phases these are orthogonal, so the contrast
and the decay of a coherence are exact linear maps of the fringe.
"""

from __future__ import annotations

import functools

import numpy as np

from dpdfit.analyses.diagnosis.effects import Prep
from dpdfit.core.defaults import ERROR_MODEL
from dpdfit.models.gate_sim.spam import spectator_outcomes

__all__ = ["observe", "knob_terms", "BranchMixer", "branch_terms", "confusion_t", "PHASES", "collapse",
           "contrast", "decohere"]

#: analysis phases of the model's fringes (the contrast does not depend on them): the
#: lab's ``ERROR_MODEL.parity_phases`` (16) equally spaced phases
PHASES = ERROR_MODEL.analysis_phases()

# design of the fringe fit: 1, cos phi, sin phi, cos 2phi, sin 2phi (exact on PHASES)
_DESIGN = np.stack([np.ones_like(PHASES), np.cos(PHASES), np.sin(PHASES), np.cos(2 * PHASES),
                    np.sin(2 * PHASES)], axis=1)
_DESIGN_PINV = np.linalg.pinv(_DESIGN)
_PINV = _DESIGN_PINV[3:5]                            # rows giving the cos/sin 2phi coefficients


def knob_terms(base, d, coefs, qs) -> dict:
    """The knobs' changes of the two-ion outcomes ``qs`` for knob weights ``coefs``
    (``{knob: array over the rows' times}``), in the order they add: they do not
    depend on the power error, so a prediction computes them once for its three
    power errors."""
    out = {q: [] for q in qs}
    for kk, c in coefs.items():
        c = np.asarray(c, dtype=float)
        if not np.any(c):
            continue
        for q in qs:
            out[q].append(d[kk][q](c.reshape(c.shape + (1,) * (base[q].ndim - c.ndim))
                                   if c.ndim else c))
    return out


def observe(base, d, lin, quad, coefs, eps, v_mean, prep: Prep, gate: bool,
            coherence=None, terms=None, det=None, mixers=None, fixed=None):
    """Measured probabilities at power error ``eps`` (dB, per row; with leading axes, e.g.
    ``(3, rows)``, the probabilities at each, along those axes) for knob weights
    ``coefs`` (``{knob: array over the rows' times}``); ``coherence``: factors
    ``(k1, k2)`` per row on the two-ion fringes' ``phi`` and ``2 phi`` harmonics.
    ``terms``: the knobs' changes (:func:`knob_terms`) when already computed;
    ``det``: the detection confusion matrix, transposed, when already made;
    ``mixers``: the preparation branches' mixers (:class:`BranchMixer`, ``{"p": ...,
    "par": ...}``), made here when missing (a dict passed in keeps them); ``fixed``: the
    fixed branches' outcome terms (:func:`branch_terms`, ``{"p": ..., "par": ...}``),
    which no parameter but the coherence moves, kept likewise across mixers."""
    eps = np.asarray(eps, dtype=float)
    vm = np.asarray(v_mean, dtype=float)
    if terms is None:
        terms = knob_terms(base, d, coefs, ("p2", "par2") if gate else ("p2",))

    def two_ion(q):
        shape = (-1,) + (1,) * (base[q].ndim - 1)
        e = eps.reshape(eps.shape + shape[1:]) if eps.ndim else eps
        v = base[q] + lin[q] * e + quad[q] * (e ** 2 + (vm.reshape(shape) if vm.ndim
                                                        else vm))
        for t in terms[q]:
            v = v + t
        return v

    if det is None:
        det = confusion_t(prep)
    mixers = {} if mixers is None else mixers
    fixed = {} if fixed is None else fixed
    if "p" not in mixers:
        if "p" not in fixed:
            fixed["p"] = branch_terms(base["p1"], base["p2_01"], base["p1_1"])
        mixers["p"] = BranchMixer(prep, base["p1"], base["p2_01"], base["p1_1"], fixed["p"])
    pop = mixers["p"](two_ion("p2")) @ det
    if not gate:
        return pop, None
    par2 = two_ion("par2")
    if coherence is not None:
        par2 = decohere(par2, *coherence)
    if "par" not in mixers:
        par2_01 = base["par2_01"]
        if coherence is not None:                # the flipped branch's terms decohered too
            par2_01 = decohere(par2_01, *coherence)
            fixed_par = None
        else:
            if "par" not in fixed:
                fixed["par"] = branch_terms(base["par1"], par2_01, base["par1_1"])
            fixed_par = fixed["par"]
        mixers["par"] = BranchMixer(prep, base["par1"], par2_01, base["par1_1"], fixed_par)
    return pop, mixers["par"](par2) @ det


def branch_terms(p1, p2_01, p1_1) -> tuple:
    """The fixed branches' outcomes as :class:`BranchMixer` weighs them, before their
    weights: a spectator with the other ion driven from ``|0>`` (``p1``), the flipped
    two-ion branch with its mirror (``p2_01``), a spectator with the other driven from
    ``|1>`` (``p1_1``).  They depend on the engine's runs only, so a fit that moves the
    preparation errors makes them once."""
    p01 = np.asarray(p2_01, dtype=float)
    return (spectator_outcomes(p1), p01 + p01[..., [0, 2, 1, 3]], spectator_outcomes(p1_1))


class BranchMixer:
    """:func:`~dpdfit.models.gate_sim.mix_branches` of two-ion outcomes ``p2`` with fixed
    other branches (the one-ion and flipped ones, which no power error or knob moves):
    their terms are made once, then added to each ``p2`` in the order ``mix_branches``
    adds them (the same values).  ``terms``: :func:`branch_terms` of the same branches,
    when already made."""

    def __init__(self, prep: Prep, p1, p2_01, p1_1, terms=None):
        q, f = prep.spectator, prep.flip
        self.q, self.f, self.g = q, f, 1.0 - q - f
        if terms is None and (q > 0 or f > 0):
            terms = branch_terms(p1, p2_01, p1_1)
        self.spec = q * self.g * terms[0] if q > 0 else None
        if f > 0:
            self.flip = f * self.g * terms[1]
            self.spec_flip = q * f * terms[2] if q > 0 else None

    def __call__(self, p2):
        q, f, g = self.q, self.f, self.g
        p2 = np.asarray(p2, dtype=float)
        out = g ** 2 * p2
        if q > 0:
            out = out + self.spec
            out[..., 0] += q ** 2
        if f > 0:
            out = out + self.flip
            out = out + f * f * p2[..., ::-1]
            if q > 0:
                out = out + self.spec_flip
        return out


def confusion_t(prep: Prep) -> np.ndarray:
    """The transposed four-outcome confusion matrix of the detection errors of ``prep``
    (:func:`~dpdfit.models.gate_sim.confusion` applies ``p4 @`` it): ``kron(C, C).T``
    with the same products, written out because a prediction makes one every time and
    ``np.kron``'s generality costs more than the sixteen products; kept for the last
    detection errors asked (a fit's Jacobian asks for the same ones again and again).
    Read-only."""
    return _confusion_t(float(prep.e01), float(prep.e10))


@functools.lru_cache(maxsize=32)
def _confusion_t(e01: float, e10: float) -> np.ndarray:
    C = ((1 - e01, e10), (e01, 1 - e10))
    # kron(C, C)[2 i + k, 2 j + l] = C[i][j] C[k][l]; transposed: row 2 j + l, column 2 i + k
    out = np.array([[C[i][j] * C[k][l] for i in (0, 1) for k in (0, 1)]
                    for j in (0, 1) for l in (0, 1)])
    out.flags.writeable = False
    return out


def collapse(p4):
    """Two-ion outcome probabilities (..., 4: 00, 01, 10, 11) as (even population, P00 - P11)."""
    return p4[..., 0] + p4[..., 3], p4[..., 0] - p4[..., 3]


def contrast(par4):
    """``cos 2 phi`` amplitude of the parity ``2 (P00 + P11) - 1`` over PHASES (last-but-one axis)."""
    parity = 2 * (par4[..., 0] + par4[..., 3]) - 1
    c = np.einsum("ij,...j->...i", _PINV, parity)
    return np.hypot(c[..., 0], c[..., 1])


def decohere(par, k1, k2):
    """Fringes ``par`` (rows, PHASES, outcomes; leading axes before the rows allowed)
    with their ``phi`` harmonic scaled by ``k1`` and their ``2 phi`` harmonic by ``k2``
    (per row): the final state's single-ion and two-ion coherences decayed, its
    populations kept (exact on PHASES)."""
    lead = par.shape[:-3]
    k1 = np.asarray(k1, dtype=float).reshape(-1, 1)
    k2 = np.asarray(k2, dtype=float).reshape(-1, 1)
    if lead:                                # one stack of rows, each row's factors kept
        n = int(np.prod(lead))
        out = decohere(par.reshape((-1,) + par.shape[-2:]), np.tile(k1, (n, 1)),
                       np.tile(k2, (n, 1)))
        return out.reshape(par.shape)
    c = np.einsum("kj,rjo->rko", _DESIGN_PINV, par)                  # (rows, 5, outcomes)
    c[:, 1:3] *= k1[:, None]
    c[:, 3:5] *= k2[:, None]
    return np.einsum("jk,rko->rjo", _DESIGN, c)
