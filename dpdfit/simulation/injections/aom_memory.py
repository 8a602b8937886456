"""How the simulator injects ``aom_memory``: the modulator's response with a memory.

The fast memory filters the drive (``inject_drive``); the slow one multiplies the
field by ``(1 + c s(t)) / (1 + c |x|^2)`` (``inject_field``): the simulator's
calibration runs are of the static AOM, so the static curve they measure must already
hold the memory's steady state, as a lab's constant-amplitude runs do.  The harness
draws slow memories of a few per cent of gain and phase at full drive (thermal time
scales 0.3-3 us, a second one of 2-8 us with weight 0.3-0.7, a delay of 50-200 ns)
and compares ``gain_abs`` for them.
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.effects.aom_memory import EFFECT, slow_kernel

from .base import Injection

__all__ = ["AomMemoryInjection", "INJECTION"]

# harness strengths of the slow memory's gain at full drive (amplitude, phase in rad)
_SLOW_GAIN = {"gain_a": (0.02, 0.06, True), "gain_p": (0.03, 0.1, True)}


class AomMemoryInjection(Injection):
    """A fast single-pole filter of the drive, or a slow gain and phase following the
    drive power (relative to the steady state the calibration runs measured)."""

    effect = EFFECT
    harness = {"tau": (40.0, 120.0, False), "f_off": (1.0, 4.0, True)}
    harness_forms = {
        "slow": {**_SLOW_GAIN, "tau1": (0.3, 3.0, False)},
        "two_scales": {**_SLOW_GAIN, "tau1": (0.3, 1.0, False), "tau2": (2.0, 8.0, False),
                       "w": (0.3, 0.7, False)},
        "two_scales_delay": {**_SLOW_GAIN, "tau1": (0.3, 1.0, False), "tau2": (2.0, 8.0, False),
                             "w": (0.3, 0.7, False), "delay": (50.0, 200.0, False)}}
    main_forms = {"slow": "gain_abs", "two_scales": "gain_abs", "two_scales_delay": "gain_abs"}

    def inject_drive(self, v, x, fs):
        tau = v.get("tau", 0.0) * 1e-9
        if tau <= 0:
            return x
        f = np.fft.fftfreq(x.shape[-1], 1.0 / fs)
        H = 1.0 / (1.0 + 2j * np.pi * (f - v.get("f_off", 0.0) * 1e6) * tau)
        return np.fft.ifft(np.fft.fft(x, axis=-1) * H, axis=-1)

    def inject_field(self, v, y, x, fs, y_full):
        if not (v.get("gain_a") or v.get("gain_p")):
            return y
        f = np.fft.fftfreq(x.shape[-1], 1.0 / fs)
        p = np.minimum(np.abs(x), 1.0) ** 2
        s = np.fft.ifft(np.fft.fft(p, axis=-1) * slow_kernel(v, f), axis=-1).real
        c = complex(v.get("gain_a", 0.0), v.get("gain_p", 0.0))
        # relative to the steady state the (static) calibration runs measured (module doc)
        return y * (1 + c * s) / (1 + c * p)


INJECTION = AomMemoryInjection()
