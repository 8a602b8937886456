"""The AOM pulse response of a campaign (``pulse_response.csv``): a fast photodiode trace of
an RF step.

The drive is switched from 0 to ``A`` at ``t = 0``; the recorded power is the optical
power of the recordings' AOM (:func:`~dpdfit.simulation.campaign.optics.optical_field`:
the injected effects' ``inject_drive``, the memoryless AOM, their ``inject_field``), in
the calibration photodiode's unit (``p_full`` at full drive) and through the injected
effects' ``inject_photodiode``, sampled at :data:`PULSE_TIMES_US`.  The field hooks
filter the drive periodically (by FFT), so the step is simulated as a square wave on a
grid of :data:`PULSE_FS_HZ` whose half period (262 us) is 30 times the longest memory the
harness draws (8 us): the step's previous switch-off has decayed to ``e^-30``.  The
sample at each switch holds half the drive: the sampled square wave's Fourier series is
then that of the continuous one to second order in the sample interval (a fast memory's
rise is off by 3e-5 of the power, not the 6e-3 of a switch on a sample).

Only a memory of the modulator (``aom_memory``) changes the trace's shape: a static
transfer (a higher-order nonlinearity, an AM-to-PM, a drifted or miscalibrated AOM, a
nonlinear detector) changes its settled level, not the response normalised to it.  Each
sample carries the campaign photodiode's noise (``PhotodiodeNoise.sigma``: a floor and
a relative part, a scope trace averaged over many steps), clipped at zero (a photodiode
reads no less than no light).  The campaign's own traces (``CampaignConfig.pulse_traces``
at the time scans' amplitude) draw from their own random stream (purpose 15), a further
one (``("pulse_response", A)`` of ``CampaignConfig.further``) from the further item's,
so that adding either leaves every other row of the campaign as it was.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from dpdfit.simulation.aom_truth import BraggAOM

from .config import CampaignConfig, rng_for
from .optics import optical_field

__all__ = ["PULSE_TIMES_US", "PULSE_FS_HZ", "PULSE_GRID", "pulse_power", "pulse_rows",
           "pulse_table", "pulse_truth"]

#: the recorded samples (us after the step): a scope trace of 4096 samples at 10 ns,
#: the acoustic rise (tens of ns) resolved and the slow memory (to 8 us) settled
PULSE_TIMES_US = np.round(np.arange(1, 4097) * 0.01, 2)
#: sampling rate of the simulated drive (2 ns: a fast memory of 40 ns has 20 samples)
PULSE_FS_HZ = 5e8
#: samples of the simulated square wave (half of them driven)
PULSE_GRID = 2 ** 18


def pulse_power(cfg: CampaignConfig, aom: BraggAOM, A: float,
                times_us=PULSE_TIMES_US) -> np.ndarray:
    """The noise-free photodiode reading at ``times_us`` after a step ``0 -> A`` (module
    doc): ``p_full`` times the field's power relative to full drive, through the
    injected effects' photodiode hooks."""
    x = np.zeros(PULSE_GRID, dtype=complex)
    x[:PULSE_GRID // 2] = A
    x[[0, PULSE_GRID // 2]] = 0.5 * A       # the switch mid-sample (module doc)
    y = optical_field(cfg, aom, x, PULSE_FS_HZ)
    k = np.rint(np.asarray(times_us, dtype=float) * 1e-6 * PULSE_FS_HZ).astype(int)
    # the field is normalised to unit slope at A = 0: |y (pi/2) u'(0)|^2 = eta / eta_ref
    power = cfg.photodiode.p_full * np.abs(y[k] * 0.5 * np.pi * aom.slope0) ** 2
    for e, v in cfg.injections():
        power = e.inject_photodiode(v, power, cfg.photodiode.p_full)
    return power


def pulse_rows(cfg: CampaignConfig, aom: BraggAOM, A: float, rng: np.random.Generator,
               run: str) -> pd.DataFrame:
    """One trace: ``run, A, t_us, power, power_err`` at :data:`PULSE_TIMES_US`, the
    reading drawn from ``rng`` (module doc)."""
    p = pulse_power(cfg, aom, A)
    sig = cfg.photodiode.sigma(p)
    power = np.maximum(p + sig * rng.standard_normal(p.size), 0.0)
    return pd.DataFrame({"run": run, "A": float(A), "t_us": PULSE_TIMES_US, "power": power,
                         "power_err": sig})


def _items(cfg: CampaignConfig, further_from: int | None):
    """``(A, rng, run label)`` of every trace the config records (module doc)."""
    out = []
    if further_from is None:
        out += [(cfg.time_scan_A, rng_for(cfg, 15, k), f"pulse{k + 1}")
                for k in range(cfg.pulse_traces)]
    k = cfg.pulse_traces + sum(1 for item in cfg.further[:further_from or 0]
                               if item[0] == "pulse_response")
    for j, item in enumerate(cfg.further):
        if j >= (further_from or 0) and item[0] == "pulse_response":
            out.append((float(item[1]), rng_for(cfg, 8, j), f"pulse{k + 1}"))
            k += 1
    return out


def pulse_table(cfg: CampaignConfig, aom: BraggAOM,
                further_from: int | None = None) -> pd.DataFrame:
    """``pulse_response.csv`` of the campaign ``cfg`` (``aom``: the recordings' AOM): its
    own traces, then the further ``("pulse_response", A)`` items of ``cfg.further``;
    empty when nothing records one.  ``further_from``: only the rows the further items
    from that index on add (the campaign's own left out)."""
    parts = [pulse_rows(cfg, aom, A, rng, run) for A, rng, run in _items(cfg, further_from)]
    if not parts:
        return pd.DataFrame(columns=["run", "A", "t_us", "power", "power_err"])
    return pd.concat(parts, ignore_index=True)


def pulse_truth(cfg: CampaignConfig, aom: BraggAOM) -> dict:
    """``truth.json``'s ``pulse_response``: each trace's amplitude and its noise-free
    settled reading (the last sample's)."""
    items = _items(cfg, None)
    return {"A": [float(A) for A, _, _ in items],
            "settled_power": [float(pulse_power(cfg, aom, A, PULSE_TIMES_US[-1:])[0])
                              for A, _, _ in items]}
