"""The AOM pulse response (``pulse_response.csv``) as data of every hypothesis: a fast
photodiode trace of an RF step ``0 -> A``.

Its prediction is the tone model's own optical field of that drive
(:meth:`~dpdfit.analyses.diagnosis.model.tones.tone_model.ToneModel.drive_field`: each
effect's :meth:`~dpdfit.analyses.diagnosis.effects.base.Effect.drive_filter` and
:meth:`~dpdfit.analyses.diagnosis.effects.base.Effect.power_memory`, the same hooks the
spectra's model applies, with the calibrated static transfer between them), its power
sampled at the recorded times.  The step is computed as a square wave by FFT on a grid of
the trace's own sample interval, on for the trace and :data:`SETTLE_US` beyond it and off
as long (the previous switch-off of a memory of the diagnosis's longest time scale, 50 us,
has decayed to ``e^-4`` of its few per cent; of the harness's, to ``e^-25``).  The sample
at each switch holds half the drive, as the simulator's: a fast memory's rise on a 10-ns
grid is then off by 1e-3 of the power, not the 3e-2 of a switch on a sample.

What it fits is the response's *shape*: each step's settled level is profiled (the
weighted least-squares scale of the prediction, :func:`pulse_block`), so a static transfer
(a higher-order nonlinearity, an AM-to-PM, a drifted calibration) and the detector's
scale or nonlinearity, which move the level and not the shape, do not enter: without a
memory the prediction is a clean step and the block constrains nothing else.  A memory
does: the acoustic response's rise and ringing (nanoseconds), the crystal's slow gain
(microseconds).  That is what the spectra alone confuse with higher-order
intermodulation.
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.model.caches import ModelCache
from dpdfit.analyses.diagnosis.model.tones.tone_model import ActiveEffects

__all__ = ["SETTLE_US", "MAX_GRID", "pulse_grid", "pulse_prediction", "pulse_block"]

#: time (us) the computed step stays on after the last recorded sample, and then off
SETTLE_US = 200.0
#: most samples of the computed square wave (a trace sampled at 1 ns over 300 us)
MAX_GRID = 2 ** 20


def pulse_grid(t_us) -> tuple:
    """``(dt_us, n)``: the computed step's sample interval (the recorded one, the smallest
    spacing of ``t_us``, within 1 ns to 50 ns) and its number of samples (a power of two
    holding the trace and :data:`SETTLE_US` twice, at most :data:`MAX_GRID`)."""
    t = np.unique(np.asarray(t_us, dtype=float))
    d = np.diff(t)
    dt = float(np.clip(d[d > 0].min() if np.any(d > 0) else 0.01, 1e-3, 0.05))
    need = 2.0 * (max(float(t.max()), 0.0) + SETTLE_US) / dt
    return dt, int(min(2 ** int(np.ceil(np.log2(need))), MAX_GRID))


def pulse_prediction(tone, p: dict, A: float, t_us) -> np.ndarray:
    """The predicted reading (up to its scale) at ``t_us`` after a step ``0 -> A`` of the
    tone model ``tone`` at the parameter set ``p``: ``|field|^2`` (module doc); 0 before
    the step."""
    t = np.asarray(t_us, dtype=float)
    dt, n = pulse_grid(t)
    freq = np.fft.fftfreq(n, dt * 1e-6)
    act = ActiveEffects(tone, p)
    if not act.filters(np.zeros(1)) and not act.memory_gains():
        # no filter and no memory: the static transfer of the drive, a clean step
        level = tone.drive_field(np.array([A], dtype=complex), np.zeros(1), p)[0]
        return np.where(t >= 0, float(np.abs(level) ** 2), 0.0)
    x = np.zeros(n, dtype=complex)
    x[:n // 2] = A
    x[[0, n // 2]] = 0.5 * A            # the switch mid-sample: second order in dt
    power = np.abs(tone.drive_field(x, freq, p)) ** 2
    grid = np.arange(n) * dt
    return np.interp(np.mod(t, n * dt), grid, power)


def _predictions(ctx, p: dict) -> dict:
    """``{A: prediction at the samples of that A}`` of ``ctx.camp.pulse_response``, kept
    for the last few tone-side parameter sets (a fit's Jacobian asks the same again)."""
    pulse = ctx.camp.pulse_response
    # the tone model too: a problem may swap it (the other phase-sign convention)
    key = (id(ctx.tone), *sorted((k, float(v)) for k, v in p.items()))
    cache = ctx.__dict__.setdefault("_pulse_cache", ModelCache(shared=True))
    out = cache.get(key)
    if out is None:
        A = pulse["A"].to_numpy(dtype=float)
        t = pulse["t_us"].to_numpy(dtype=float)
        out = np.empty(A.size)
        for a in np.unique(A):
            sel = A == a
            out[sel] = pulse_prediction(ctx.tone, p, float(a), t[sel])
        cache[key] = out
    return out


def pulse_block(ctx, p: dict) -> tuple:
    """``(label, z)``: the standardised residuals of ``ctx.camp.pulse_response`` (one per
    sample) at the tone-side parameter set ``p``: ``(power - s m) / sigma``, ``m`` the
    prediction, ``s`` each step's weighted least-squares scale (its settled level)."""
    pulse = ctx.camp.pulse_response
    m = _predictions(ctx, p)
    y = pulse["power"].to_numpy(dtype=float)
    w = 1.0 / pulse["sigma"].to_numpy(dtype=float) ** 2
    step = pulse["step"].to_numpy()
    _, inv = np.unique(step, return_inverse=True)
    num = np.bincount(inv, weights=w * y * m)
    den = np.bincount(inv, weights=w * m * m)
    s = np.divide(num, den, out=np.zeros_like(num), where=den > 0)
    z = (y - s[inv] * m) * np.sqrt(w)
    return {"kind": "pulse_response", "observable": "pulse_response"}, z
