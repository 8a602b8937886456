"""Sideband thermometry of the gate mode: what the probed ion reads after a sideband pulse.

One model, used by the simulator (:mod:`dpdfit.simulation.campaign.thermometry_runs`) and
by the diagnosis's prediction
(:mod:`dpdfit.analyses.diagnosis.model.thermometry_block`), so that the two cannot
disagree.

The mode is thermal with mean occupation ``nbar(t) = nbar0 + ndot t`` after a wait ``t``
(``p_n = nbar^n / (nbar + 1)^(n + 1)``).  The probe is a fixed pulse on the red or blue
motional sideband of the probed ion, of area :data:`PROBE_PULSE_AREA` (a pi pulse of the
blue sideband from the ground state).  In the Lamb-Dicke regime the sideband Rabi
frequencies are ``eta Omega sqrt(n + 1)`` (blue, ``|0, n>`` to ``|1, n + 1>``) and ``eta
Omega sqrt(n)`` (red, ``|0, n>`` to ``|1, n - 1>``); with the pulse fixed by its area on
the ground state the campaign's ``eta`` drops out.  The excitation is the thermal average
of the Rabi flopping (:func:`sideband_excitation`)::

    P_blue = sum_n p_n sin^2(theta sqrt(n + 1) / 2),  P_red = sum_n p_n sin^2(theta sqrt(n) / 2)

For a weak pulse this is the familiar ``P_red / P_blue = nbar / (nbar + 1)``; the exact
average also holds for the pi pulse and for a hot mode.

Preparation and detection (:func:`bright_probability`): the probed ion is a *spectator*
(a level outside the qubit: not driven, reads bright) with probability ``spectator``, in
the wrong qubit state ``1`` with probability ``flip`` (from ``|1, n>`` the blue sideband
couples to ``|0, n - 1>`` with ``sqrt(n)``, the red one to ``|0, n + 1>`` with ``sqrt(n
+ 1)``: a flipped ion sees the other sideband's excitation), right otherwise; the state
``0`` is bright.  The reading is flipped with the detection errors ``e01`` (bright read
dark) and ``e10`` (dark read bright).  Only the occupation and these errors change it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["PROBE_PULSE_AREA", "SIDEBANDS", "THERMOMETRY_WAITS_US", "sideband_excitation",
           "bright_probability", "mean_occupation"]

#: the probe's pulse area (rad) on the blue sideband of the ground state: a pi pulse
PROBE_PULSE_AREA = np.pi
#: the sidebands a probe drives
SIDEBANDS = ("red", "blue")
#: the waits (us) of a thermometry recording as the menu proposes it and the simulator
#: records it: 0 to 10 ms, where a mode heating at the lab's 5 quanta/s gains 0.05
#: quanta and one heating at 0.05 to 0.2 quanta/ms gains 0.5 to 2
THERMOMETRY_WAITS_US = (0.0, 250.0, 500.0, 1000.0, 2000.0, 4000.0, 7000.0, 10000.0)
#: Fock states summed: up to where the thermal tail is below 1e-12, at most this many
_MAX_FOCK = 200_000


def mean_occupation(nbar0: float, ndot_per_s: float, wait_s) -> np.ndarray:
    """``nbar0 + ndot t`` at the waits ``wait_s`` (s), floored at 0 (a fit may try a
    negative heating rate)."""
    return np.maximum(float(nbar0) + float(ndot_per_s) * np.asarray(wait_s, dtype=float), 0.0)


def sideband_excitation(nbar, sideband, area: float = PROBE_PULSE_AREA) -> np.ndarray:
    """Probability that a probe pulse of ``area`` on ``sideband`` (``"red"`` or
    ``"blue"``, one per ``nbar``) takes an ion from ``0`` to ``1``, for thermal states
    of mean occupation ``nbar`` (the thermal average of the module doc)."""
    nbar = np.atleast_1d(np.asarray(nbar, dtype=float))
    blue = np.broadcast_to(np.asarray(sideband) == "blue", nbar.shape)
    r = nbar / (nbar + 1.0)
    top = float(np.max(r))
    cut = 1 if top <= 0 else int(np.ceil(np.log(1e-12) / np.log(top))) + 2
    n = np.arange(min(max(cut, 2), _MAX_FOCK), dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        logp = np.where(r[:, None] > 0, n * np.log(np.where(r > 0, r, 1.0))[:, None], 0.0)
    p = np.where((r[:, None] > 0) | (n == 0), np.exp(logp) * (1.0 - r)[:, None], 0.0)
    p /= p.sum(axis=1, keepdims=True)
    rabi = np.where(blue[:, None], np.sqrt(n + 1.0), np.sqrt(n))
    return np.sum(p * np.sin(area * rabi / 2.0) ** 2, axis=1)


def bright_probability(nbar, sideband, spectator: float, flip: float, e01: float,
                       e10: float, area: float = PROBE_PULSE_AREA) -> np.ndarray:
    """Probability that the probed ion reads bright after the probe on ``sideband`` at
    mean occupations ``nbar``, with the preparation and detection errors of the module
    doc."""
    sideband = np.broadcast_to(np.asarray(sideband), np.shape(np.atleast_1d(nbar)))
    other = np.where(sideband == "blue", "red", "blue")
    excite = sideband_excitation(nbar, sideband, area)
    back = sideband_excitation(nbar, other, area)
    right = 1.0 - float(spectator) - float(flip)
    dark = right * excite + float(flip) * (1.0 - back)
    read_dark = dark * (1.0 - float(e10)) + (1.0 - dark) * float(e01)
    return 1.0 - read_dark
