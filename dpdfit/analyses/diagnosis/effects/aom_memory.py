"""``aom_memory``: the modulator's response has a memory.

Family (two kinds of memory):

* form ``fast`` (catalog): the acoustic response to the drive envelope, a
  single pole ``H(f) = 1/(1 + i 2 pi (f - f_off) tau)`` before the static
  transfer (Wiener model; nanoseconds).  ``f_off != 0`` makes red and blue
  differ, so its spectra depend on the phase-sign convention.
* forms ``slow``, ``two_scales``, ``two_scales_delay``: a slow memory
  (microseconds, e.g. heating of the crystal by the RF): the modulator's
  complex gain is ``1 + (gain_a + i gain_p) s(t)``, ``s`` the drive power
  ``|x|^2`` through the kernel

      H(f) = exp(-i 2 pi f delay) [(1 - w) / (1 + i 2 pi f tau1) + w / (1 + i 2 pi f tau2)]

  -- one time scale (``slow``: ``w = 0``), two (``two_scales``: two decays for
  ``0 < w < 1``; a rise of time ``tau1`` and a decay ``tau2``,
  ``1/((1 + i 2 pi f tau1)(1 + i 2 pi f tau2))``, for ``w = tau2/(tau2 - tau1) > 1``),
  and a delay (``two_scales_delay``).  The calibration runs drive a constant
  amplitude, so the memory's steady state (gain ``1 + c |x|^2``: ``H(0) = 1``) is
  already inside the measured transfer: the field is the calibrated transfer
  times ``(1 + c s(t)) / (1 + c |x|^2)``.

Priors: flat inside the bounds below.  Sizes: ``tau_ns``, ``f_off_MHz`` (fast);
``tau1_us``, ``tau2_us``, ``weight2``, ``delay_ns``, ``gain_abs``,
``gain_phase_rad`` (slow; the harness compares ``gain_abs``).  Both chi2 surfaces
are multimodal: the fits start from coarse seed grids, each larger form from the
smaller one's optimum.
"""

from __future__ import annotations

import numpy as np

from .base import Effect, Form, Param

__all__ = ["AomMemory", "EFFECT", "slow_kernel", "FAST_GRID", "SLOW_GRID"]

#: coarse grids seeding the fits: fast tau (ns) x f_off (MHz); slow tau1 (us) x gain_p
FAST_GRID = ((30.0, 90.0), (-4.0, -1.5, 1.5, 4.0))
SLOW_GRID = ((0.3, 1.0, 3.0, 10.0), (-0.3, -0.1, -0.02, 0.02, 0.1, 0.3))


def slow_kernel(v: dict, f: np.ndarray) -> np.ndarray:
    """The slow memory's kernel ``H(f)`` (module doc) at frequencies ``f`` (Hz)."""
    s = 2j * np.pi * np.asarray(f, dtype=float)
    t1 = max(v.get("tau1", 0.0), 0.0) * 1e-6
    t2 = max(v.get("tau2", 0.0), 0.0) * 1e-6
    w = v.get("w", 0.0)
    H = (1 - w) / (1 + s * t1) + (w / (1 + s * t2) if w else 0.0)
    d = v.get("delay", 0.0) * 1e-9
    return H * np.exp(-s * d) if d else H


class AomMemory(Effect):
    """A modulator response with memory: a fast single-pole acoustic response
    (``fast``, catalog) or a slow gain and phase following the drive power through
    one or two time scales (``slow``, ``two_scales``, ``two_scales_delay``)."""

    name = "aom_memory"
    side = "tones"
    meaning = "the modulator's response has a memory (fast acoustic or slow thermal)"
    params = (Param("tau", "ns", 0.0, 400.0, 30.0, 20.0, "fast response time"),
              Param("f_off", "MHz", -20.0, 20.0, 0.0, 1.0, "centre offset of the fast response"),
              Param("gain_a", "1", -2.0, 2.0, 0.0, 0.01, "slow gain change per unit drive power"),
              Param("gain_p", "rad", -3.0, 3.0, 0.01, 0.01,
                    "slow phase change per unit drive power"),
              Param("tau1", "us", 0.01, 50.0, 1.0, 0.3, "first time scale of the slow kernel"),
              Param("tau2", "us", 0.01, 50.0, 3.0, 0.3, "second time scale"),
              Param("w", "1", -5.0, 5.0, 0.0, 0.1, "weight of the second time scale"),
              Param("delay", "ns", 0.0, 500.0, 0.0, 10.0, "delay of the slow kernel"))
    _SLOW_OFF = {"gain_a": 0.0, "gain_p": 0.0, "tau1": 1.0, "tau2": 3.0, "w": 0.0,
                 "delay": 0.0}
    forms = (Form("fast", ("tau", "f_off"), _SLOW_OFF, "single-pole acoustic response",
                  seed_grid=(("tau", "f_off"), FAST_GRID)),
             Form("slow", ("gain_a", "gain_p", "tau1"),
                  {"tau": 0.0, "f_off": 0.0, "tau2": 3.0, "w": 0.0, "delay": 0.0},
                  "gain following the drive power through one time scale",
                  seed_grid=(("tau1", "gain_p"), SLOW_GRID)),
             Form("two_scales", ("gain_a", "gain_p", "tau1", "tau2", "w"),
                  {"tau": 0.0, "f_off": 0.0, "delay": 0.0},
                  "two time scales (two decays, or a rise and a decay)", starts_from="slow",
                  extra_starts=({"w": 0.3, "tau2": 0.3}, {"w": 1.2, "tau2": 3.0, "tau1": 0.3})),
             Form("two_scales_delay", ("gain_a", "gain_p", "tau1", "tau2", "w", "delay"),
                  {"tau": 0.0, "f_off": 0.0}, "two time scales and a delay",
                  starts_from="two_scales", extra_starts=({"delay": 60.0},)))
    phase_odd = ("gain_p",)
    sign_sensitive = True
    main = "tau_ns"

    def drive_filter(self, tm, v, f):
        tau = v.get("tau", 0.0) * 1e-9
        if tau <= 0:
            return None
        return 1.0 / (1.0 + 2j * np.pi * (f - v.get("f_off", 0.0) * 1e6) * tau)

    def power_memory(self, tm, v, f):
        if not (v.get("gain_a") or v.get("gain_p")):
            return None
        return v.get("gain_a", 0.0) + 1j * v.get("gain_p", 0.0), slow_kernel(v, f)

    def size_values(self, ctx, p):
        v = self.values(p) or {}
        if v.get("gain_a") or v.get("gain_p"):
            g = complex(v.get("gain_a", 0.0), v.get("gain_p", 0.0))
            return {"tau1_us": (v.get("tau1", 0.0), "us", "first time scale"),
                    "tau2_us": (v.get("tau2", 0.0), "us", "second time scale"),
                    "weight2": (v.get("w", 0.0), "1",
                                "weight of the second time scale (> 1: tau1 a rise)"),
                    "delay_ns": (v.get("delay", 0.0), "ns", "delay of the kernel"),
                    "gain_abs": (abs(g), "1/full power", "size of the gain change"),
                    "gain_phase_rad": (float(np.angle(g)), "rad", "its phase")}
        return {"tau_ns": (v.get("tau", 0.0), "ns", "response time of the modulator"),
                "f_off_MHz": (v.get("f_off", 0.0), "MHz", "offset of its response centre")}


EFFECT = AomMemory()
