"""The envelope engine of the tone model (:mod:`~dpdfit.analyses.diagnosis.model.tones.tone_model`).

Every memoryless field, and the slow power memory: the band at ``+nu`` of a memoryless
odd nonlinearity of the Cardioid's drive is ``G_1(|2 A eps(t)|/peak) e^{i arg eps(t)} / 2``
of its slow complex envelope ``eps``, ``G_m`` tabulated by Gauss-Legendre quadrature
(the tone model's docstring has the whole method).

What a fit moves is cached, each part under what it depends on (least recently used
dropped, ``CACHE_ENTRIES`` each), so that an evaluation recomputes only what its
parameters change:

* the quadrature nodes, the drive magnitudes at them (through the table) and the
  drive power's tables ``S_m``: the table only;
* the cubic interpolation weights of the slow envelope's magnitudes: the amplitudes;
* the harmonic tables ``G_m`` and the memoryless bands: the transfer's coefficients,
  the table, the effects' static transfers and a slow memory's gain, not its kernel
  (a slow memory's time scales and delay move only the last, cheap step).

Every cached value is the one the computation would give again (the same operations on
the same numbers).
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.effects.base import Effect
from dpdfit.analyses.diagnosis.model.caches import ModelCache
from dpdfit.analyses.diagnosis.model.tones.interpolation import (cubic_apply, cubic_weights,
                                                                 uniform_interp)
from dpdfit.models.waveforms import cardioid, drive_peak, sample_grid

__all__ = ["EnvelopeEngine", "M_SLOW", "K_TABLE", "N_QUAD", "STATIC_MEMO_ENTRIES"]

#: samples of the slow envelope per gate period (envelope engine)
M_SLOW = 128
#: amplitudes of the harmonic tables G_m(u) on [0, 1], and quadrature nodes per piece
K_TABLE = 256
N_QUAD = 16
#: parts of the static field kept per table of magnitudes (the quadrature's, the
#: time-domain engine's): a Jacobian's columns move the amplitude curve and the phase
#: curve one at a time (``ToneModel._static_memo``)
STATIC_MEMO_ENTRIES = 16
#: harmonics of the drive power's components through a slow memory's kernel (x nu)
_POWER_M = (0, 2, -2, 4, -4)
#: harmonics of the field's bands that a slow memory mixes (x nu)
_ODD_M = (1, -1, 3, -3, 5, -5)
#: the products a slow memory adds to the band at +nu (first row) and -nu (second): the
#: field's band ``_ODD_M[_PAIRS[0][b, j]]`` times the drive power's component
#: ``_POWER_M[_PAIRS[1][b, j]]`` (their harmonics add up to +-1), summed over j in order
_PAIRS = (np.array([[0, 1, 2, 3, 4], [1, 0, 3, 2, 5]]),
          np.array([[0, 1, 2, 3, 4], [0, 2, 1, 4, 3]]))
#: the harmonic table (row of G: m = 1, 3, 5) of each band of _PAIRS
_PAIRS_G = np.array([[0, 0, 1, 1, 2], [0, 0, 1, 1, 2]])


class EnvelopeEngine:
    """The envelope engine's part of :class:`~dpdfit.analyses.diagnosis.model.tones.tone_model.ToneModel`
    (a mixin: it reads the model's ``nu``, ``xi0``, ``phase_sign``, ``_static`` and
    ``_coefficients``, ``_table``)."""

    def _setup_envelope(self):
        tones = cardioid()
        grid = sample_grid(self.nu, self.xi0, tones, extra_harmonics=(-2, 0, 3, 5))
        self._grid0 = grid
        # peak of the continuous drive (what synthesize normalises to A)
        peak = drive_peak(tones, grid)
        t = np.arange(M_SLOW) / (M_SLOW * self.xi0)
        eps = np.zeros(M_SLOW, dtype=complex)
        for n, r, ph in zip(tones.n, tones.r_blue, tones.phi_blue):
            eps += r * np.exp(1j * (2 * np.pi * n * self.xi0 * t + ph))
        self._E_unit = 2 * np.abs(eps) / peak               # |drive| per unit A
        self._rot = np.exp(1j * np.angle(eps))              # e^{i arg eps}
        # quadrature on [0, pi/2], split at the clip point (per table amplitude)
        self._Eg = np.linspace(0.0, 1.0, K_TABLE + 1)
        self._gx, self._gw = np.polynomial.legendre.leggauss(N_QUAD)
        self._k_slow = np.fft.fftfreq(M_SLOW, 1.0 / M_SLOW)   # slow harmonic index
        rot = self._rot
        self._rot_powers = {1: rot, -1: np.conj(rot)}
        for k in range(2, 6):
            self._rot_powers[k], self._rot_powers[-k] = rot ** k, np.conj(rot) ** k
        self._rot_pairs = np.stack([self._rot_powers[m] for m in _ODD_M])[_PAIRS[0]]
        # frequencies of the drive power's components at 0, +-2 nu, +-4 nu (slow memory)
        f_slow = self._k_slow * self.xi0
        self._f_power = np.stack([m * self.nu + f_slow for m in _POWER_M])

    def _quadrature(self, table):
        """The quadrature of the harmonic tables for ``table`` (None: without DPD), on
        both sides of the clip point (the first axis: the piece above it, then below):
        the nodes' angles ``th``, weights ``w``, drive magnitudes ``x`` and ``cos(m th)``
        (m = 1..5).  It depends on the table only, so it is cached (a fit moves the
        transfer far more often than the table)."""
        key = self._table_key(table)
        cache = self.__dict__.setdefault("_quad_cache", ModelCache(shared=True))
        quad = cache.get(key)
        if quad is not None:
            return quad
        Eg = self._Eg
        if table is None:
            u_c = 1.0
        else:
            sat = np.nonzero(table >= 1.0)[0]
            u_c = sat[0] / (table.size - 1) if sat.size else 1.0 + 1e-12
        thc = np.where(Eg > u_c, np.arccos(np.minimum(u_c / np.maximum(Eg, 1e-300), 1.0)), 0.0)
        th, w = [], []
        for lo, hi in ((thc, np.full_like(Eg, np.pi / 2)), (np.zeros_like(Eg), thc)):
            th.append(lo[:, None] + (self._gx[None, :] + 1) / 2 * (hi - lo)[:, None])
            w.append(self._gw[None, :] * (hi - lo)[:, None] / 2)
        th, w = np.stack(th), np.stack(w)
        u = Eg[:, None] * np.cos(th)
        x = u if table is None else uniform_interp(u, table)
        cos = {m: np.cos(m * th) for m in range(1, 6)}
        quad = {"th": th, "w": w, "x": x, "cos": cos, "cos_odd": np.stack([cos[1], cos[3], cos[5]]),
                "memo": ModelCache(STATIC_MEMO_ENTRIES, shared=True)}
        cache[key] = quad
        return quad

    def _harmonics(self, coef, table, act, memory: bool) -> np.ndarray:
        """Tables of ``G_m(u)`` (m = 1[, 3, 5]) of the field over ``u`` on [0, 1] (module
        doc)."""
        q = self._quadrature(table)
        g = self._static_memo(q["x"], coef, act, q["memo"])   # both pieces at once
        cos = q["cos_odd"] if memory else q["cos_odd"][:1]     # m = 1, 3, 5 at once
        part = (4 / np.pi) * np.sum(g * cos * q["w"], axis=-1)
        return part[:, 0] + part[:, 1]

    def _power_harmonics(self, table) -> np.ndarray:
        """Tables of ``S_m(u)`` (m = 0, 2, 4) of the drive power over ``u`` on [0, 1]
        (module doc): they depend on the table only."""
        q = self._quadrature(table)
        w, cos = q["w"], q["cos"]
        pw = np.minimum(q["x"], 1.0) ** 2
        S = np.empty((3, self._Eg.size))
        for j, (c, wm) in enumerate(((2 / np.pi, None), (4 / np.pi, cos[2]), (4 / np.pi, cos[4]))):
            part = c * np.sum((pw * w) if wm is None else (pw * wm * w), axis=-1)
            S[j] = part[0] + part[1]
        return S

    def _static_key(self, coef, table, act, memory: bool) -> tuple:
        """What the harmonic tables depend on: the transfer's coefficients, the table,
        the hooks that act on the static field (an effect's ``transfer``, a memory's
        gain: its kernel does not enter them) and whether a memory is present."""
        parts = [self.phase_sign, memory, coef[0].dtype.str, coef[0].tobytes(),
                 coef[1].dtype.str, coef[1].tobytes(), self._table_key(table)]
        gains = {id(e): gain for e, _, gain in act.memory_gains()}
        for e, v in act.items:
            if type(e).transfer is not Effect.transfer:
                parts.append((e.name, tuple(sorted(v.items()))))
            if id(e) in gains:
                parts.append((e.name, complex(gains[id(e)])))
        return tuple(parts)

    def _slow_parts(self, A, coef, table, act, memory: bool) -> dict:
        """The slow signals of the bands that do not depend on a memory's kernel, cached
        (a slow memory's fit moves its kernel's time scales at fixed harmonic tables):
        ``bands`` (the memoryless bands at +nu and -nu, shape (2, len(A), M_SLOW)) and, with
        ``memory``, ``pairs`` (the field's bands at +-1, 3, 5 nu that multiply the drive
        power's components, in the order of :data:`_PAIRS`) and ``pc_fft`` (the spectra
        of the drive power's components at 0, +-2, +-4 nu, rows in the order of
        ``_POWER_M``)."""
        A = np.ascontiguousarray(A, dtype=float)
        key = (A.tobytes(), self._static_key(coef, table, act, memory))
        cache = self.__dict__.setdefault("_slow_cache", ModelCache(shared=True))
        out = cache.get(key)
        if out is not None:
            return out
        wts = self._cubic_weights(A)
        g = cubic_apply(self._harmonics(coef, table, act, memory), wts) / 2
        if memory:
            # the field's bands at +-m nu (G_m times e^{+-i m arg eps}) as _PAIRS takes
            # them; the first of each row is the band at +nu (-nu) itself
            pairs = g[_PAIRS_G] * self._rot_pairs[:, :, None, :]
            out = {"bands": pairs[:, 0], "pairs": pairs,
                   "pc_fft": self._power_spectra(A, table, wts)}
        else:
            out = {"bands": g[0][None, :, :] * self._rot_pairs[:, 0, None, :]}
        cache[key] = out
        return out

    def _power_spectra(self, A, table, wts) -> np.ndarray:
        """Spectra (along the slow time) of the drive power's components at 0, +-2 nu,
        +-4 nu for amplitudes ``A``, cached: they depend on the table only."""
        key = (A.tobytes(), self._table_key(table))
        cache = self.__dict__.setdefault("_power_cache", ModelCache(shared=True))
        out = cache.get(key)
        if out is not None:
            return out
        rp = self._rot_powers
        s0, s2, s4 = cubic_apply(self._power_harmonics(table), wts)
        pc = {0: s0.astype(complex), 2: s2 * rp[2] / 2, -2: s2 * rp[-2] / 2,
              4: s4 * rp[4] / 2, -4: s4 * rp[-4] / 2}
        out = np.stack([np.fft.fft(pc[m], axis=-1) for m in _POWER_M])
        cache[key] = out
        return out

    def _cubic_weights(self, A: np.ndarray):
        """Cubic interpolation weights of the harmonic tables at the slow envelope's
        magnitudes ``A |eps(t)|`` (fixed by the amplitudes, so cached per ``A``)."""
        key = A.tobytes()
        cache = self.__dict__.setdefault("_weights_cache", ModelCache())
        out = cache.get(key)
        if out is None:
            out = cache[key] = cubic_weights(A[:, None] * self._E_unit[None, :], K_TABLE)
        return out

    def _bands(self, A, coef, table, act) -> np.ndarray:
        """Slow complex envelopes of the field's bands at +nu (blue) and -nu (red) for
        drive amplitudes ``A``: shape (2 [blue, red], len(A), M_SLOW)."""
        mems = act.memory_gains()
        parts = self._slow_parts(A, coef, table, act, bool(mems))
        out = parts["bands"]
        # the drive power's components at 0, +-2 nu, +-4 nu, each through the kernel at
        # its own frequencies, times the field's band that brings them to +-nu (every
        # memory present adds its own term): both bands' five products summed at once,
        # in the order of _PAIRS
        for e, v, gain in mems:
            H = e.power_memory(self, v, self._f_power)[1]            # (5, M_SLOW)
            s = self._filtered_power(A, table, parts["pc_fft"], H)
            out = out + gain * np.sum(parts["pairs"] * s, axis=1)
        return out

    def _filtered_power(self, A, table, pc_fft, H) -> np.ndarray:
        """The drive power's components (the spectra ``pc_fft``) through the kernel ``H``,
        arranged as :data:`_PAIRS` pairs them with the field's bands: shape (2, 5,
        len(A), M_SLOW).  Cached by the kernel's values: a fit moves the gain, the
        calibration modes and the nuisances more often than the kernel's time scales."""
        key = (A.tobytes(), self._table_key(table), H.dtype.str, H.tobytes())
        cache = self.__dict__.setdefault("_filtered_power_cache", ModelCache(shared=True))
        out = cache.get(key)
        if out is None:
            s = np.fft.ifft(pc_fft * H[:, None, :], axis=-1)
            out = cache[key] = s[_PAIRS[1]]
        return out

    def _table_key(self, table):
        """A hashable key of a predistortion table's exact values (None: without DPD),
        kept for the last few table objects (each held, so that its id stays its own)."""
        if table is None:
            return None
        cache = self.__dict__.setdefault("_table_key_cache", ModelCache(4))
        hit = cache.get(id(table))
        if hit is not None and hit[0] is table:
            return hit[1]
        key = table.tobytes()
        cache[id(table)] = (table, key)
        return key

    def _tones_envelope(self, A, p, act, dpd_flags, harmonics):
        coef = self._coefficients(p, act)
        n = np.asarray(harmonics)
        out = []
        for d in dpd_flags:
            bands = self._bands(A, coef, self._table(act) if d else None, act)
            cb, cr = np.fft.fft(bands, axis=-1)                   # both in one call
            out.append(np.stack([cr[:, (-n) % M_SLOW], cb[:, n % M_SLOW]], axis=1) / M_SLOW)
        return np.stack(out, axis=1)                         # (nA, n flags, 2 sb, H)
