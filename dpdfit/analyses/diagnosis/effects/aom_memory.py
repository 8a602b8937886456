"""``aom_memory``: the modulator's response has a memory.

Catalog form ("fast"): single-pole response of the modulator to its drive
envelope, ``H(f) = 1/(1 + i 2 pi (f - f_off) tau)``, before the static
transfer (Wiener model): the acoustic response of nanoseconds.  ``f_off != 0``
makes red and blue differ, so its spectra depend on the phase-sign convention.

Variant "thermal": a slow memory (microseconds: heating of the crystal by the
RF), the drive power's recent history changing the modulator's complex gain
by ``(th_a + i th_p) s(t)``, ``s`` the drive power ``|x|^2`` through a single
pole of time constant ``th_tau``.

Both chi2 surfaces are multimodal (the fast memory's: a valley per sign of
``f_off`` and local minima along ``tau x f_off``; the thermal memory's along
``th_tau``): their fits start from a coarse seed grid.
"""

from __future__ import annotations

from .base import Effect, Param

__all__ = ["AOM_MEMORY", "AOM_MEMORY_THERMAL", "MEMORY_GRID_TAU", "MEMORY_GRID_FOFF",
           "THERMAL_GRID_TAU", "THERMAL_GRID_P"]

#: coarse grid seeding the fast memory's fit: tau (ns) x f_off (MHz)
MEMORY_GRID_TAU = (20.0, 45.0, 75.0, 110.0, 160.0)
MEMORY_GRID_FOFF = (-4.5, -3.0, -2.0, -1.2, -0.6, 0.6, 1.2, 2.0, 3.0, 4.5)
#: coarse grid seeding the thermal memory's fit: th_tau (us) x th_p (rad)
THERMAL_GRID_TAU = (0.3, 1.0, 3.0, 10.0)
THERMAL_GRID_P = (-0.1, -0.02, 0.02, 0.1)

AOM_MEMORY = Effect(
    "aom_memory", "tones",
    (Param("tau", "ns", 0.0, 400.0, 30.0, 20.0),
     Param("f_off", "MHz", -20.0, 20.0, 0.0, 1.0)),
    "finite response time of the modulator to its drive envelope (single pole)",
    form="fast", seed_grid=(("tau", "f_off"), (MEMORY_GRID_TAU, MEMORY_GRID_FOFF)),
    sign_sensitive=True)

AOM_MEMORY_THERMAL = Effect(
    "aom_memory", "tones",
    (Param("th_a", "1", -0.5, 0.5, 0.0, 0.01), Param("th_p", "rad", -1.0, 1.0, 0.01, 0.01),
     Param("th_tau", "us", 0.0, 20.0, 1.0, 0.3)),
    "slow memory of the modulator (e.g. thermal): its complex gain changes by "
    "(th_a + i th_p) s(t), s = the drive power |x|^2 through a single pole of time "
    "constant th_tau",
    form="thermal", variant=True,
    seed_grid=(("th_tau", "th_p"), (THERMAL_GRID_TAU, THERMAL_GRID_P)), phase_odd=("th_p",))
