"""The forward model of a campaign's tone powers (the tone side of the diagnosis).

The *baseline* is the simulation built from the campaign's own calibration:
the AM/PM polynomials of the model runs, the predistortion table computed
from the amplitude run that ``campaign.json`` names (4096 points, linear
interpolation, as the AWG applies it) and the Cardioid(1,2) waveform.  Its
nuisances are the calibration's error modes (``cal_amp*``, ``cal_phase*``:
directions of the fit covariance that move y(A), phi(A) most, N(0, 1)
priors) and, without a phase file, the AOM's own AM-to-PM ``pm_x``.  Effects
(:mod:`dpdfit.analyses.diagnosis.effects`) change the field through their
hooks: the transfer's coefficients, the table's calibration, a memoryless
transfer after the static curve, a filter of the drive, a gain that follows
the filtered drive power.

Two engines compute the tones, chosen by the effects present:

* **Envelope** (every memoryless field, and the slow power memory).  The
  Cardioid's drive is ``w(t) = 2 A Re[e^{i 2 pi nu t} eps(t)] / peak`` with a
  slow complex envelope ``eps`` (period ``1/xi0``).  A memoryless odd
  nonlinearity ``g`` of the real drive ``u cos theta`` has the Fourier series
  ``sum_m G_m(u) cos(m theta)`` (odd m), so the band at ``+nu`` is
  ``G_1(|2 A eps(t)|/peak) e^{i arg eps(t)} / 2``: its tones are the Fourier
  coefficients of that slow signal (``M_SLOW`` samples per period) -- exact up
  to the overlap of the band at ``3 nu`` (a hundred gate harmonics away).
  ``G_m`` is tabulated on ``K_TABLE + 1`` amplitudes by Gauss-Legendre
  quadrature over ``theta`` (``N_QUAD`` nodes on each side of the point where the
  drive clips, which is the only non-smooth point) and interpolated (cubic).
  A gain ``1 + c s(t)`` following the drive power ``s = h * |x|^2`` mixes the
  harmonics of ``g`` and of ``|x|^2`` (DC, ``2 nu``, ``4 nu``), each filtered
  at its own frequencies.  Against a 16x-oversampled time-domain field the
  tones used agree to <= 0.004 dB at 60-80 dB below the gate tones, 20x faster
  than the previous time-domain model (whose 4x grid was off by 0.02 dB there).
* **Time domain** (a filter of the drive before the static transfer, the fast
  acoustic memory, whose drive is no longer a real envelope times a carrier):
  the field on the exact no-alias grid of :mod:`dpdfit.models.waveforms`,
  ``OVERSAMPLE`` x beyond the single-nonlinearity rate, the static transfer
  tabulated (``STATIC_TABLE``).

The envelope engine is :mod:`~dpdfit.analyses.diagnosis.model.tones.envelope`.  Both keep what
a fit evaluates again (:mod:`~dpdfit.analyses.diagnosis.model.caches`): the envelope engine
each of its tables under what it depends on, the time-domain engine the drive through
the fast memory's filter (a fit moves the calibration modes and nuisances far more often
than the filter), the model the features of its last few parameter sets.  A cached
value is the one the computation would give again.
"""

from __future__ import annotations

import copy

import numpy as np

from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.analyses.diagnosis.model.caches import ModelCache
from dpdfit.analyses.diagnosis.model.tones.envelope import (K_TABLE, M_SLOW, N_QUAD,
                                                            STATIC_MEMO_ENTRIES, EnvelopeEngine)
from dpdfit.analyses.diagnosis.model.tones.interpolation import (uniform_at, uniform_interp,
                                                                 uniform_place)
from dpdfit.analyses.diagnosis.observables.campaign import Campaign
from dpdfit.analyses.diagnosis.observables.tone_features import (TONE_HARMONICS,
                                                                 tone_features)
from dpdfit.core.defaults import ERROR_MODEL
from dpdfit.models import gate_sim
from dpdfit.models.transfer import TransferFunction, predistortion_table
from dpdfit.models.waveforms import cardioid, sample_grid, synthesize

__all__ = ['ToneModel', 'ActiveEffects', 'OVERSAMPLE', 'M_SLOW', 'K_TABLE', 'N_QUAD', 'GATE_HARMONICS', 'STATIC_TABLE', 'calibration_error_modes']

#: oversampling of the time-domain grid beyond the single-nonlinearity no-alias rate,
#: without and with DPD: against a 16x grid the DPD-off tones agree exactly already at
#: 1x, the DPD-on tones (the table clips at high A) to 0.07 dB at 2x and at 4x alike
OVERSAMPLE = (1, 2)
#: magnitudes of the tabulated static transfer of the time-domain engine
STATIC_TABLE = 8192
#: harmonics of the gate tones handed to the gate engine
GATE_HARMONICS = tuple(range(-2, 6))
#: filtered drives kept by the time-domain engine (megabytes each: a Jacobian's worth)
_TD_CACHE_ENTRIES = 6


class ActiveEffects:
    """The tone-side effects present in a parameter set with their values, in the order
    their hooks apply (:attr:`~dpdfit.analyses.diagnosis.effects.base.Effect.stage`)."""

    def __init__(self, tm, p: dict):
        self.items = []
        # an effect is present only if a key carries its name before the dot: the others
        # are not asked (a fit evaluates this thousands of times)
        named = {k.partition(".")[0] for k in p}
        for e in EFFECTS.values():
            if e.side != "tones" or e.name not in named:
                continue
            v = e.values(p)
            if v is not None:
                self.items.append((e, v))
        self.items.sort(key=lambda ev: ev[0].stage)
        self.tm = tm
        self._gains = None

    def memory_gains(self) -> list:
        """``[(effect, values, gain)]`` of the present effects with a power memory (the
        ``gain`` of :meth:`~dpdfit.analyses.diagnosis.effects.base.Effect.power_memory`),
        in the order they apply; asked once per parameter set."""
        if self._gains is None:
            self._gains = []
            for e, v in self.items:
                mem = e.power_memory(self.tm, v, np.zeros(1))
                if mem is not None:
                    self._gains.append((e, v, mem[0]))
        return self._gains

    def filters(self, f):
        """The present effects' linear filters ``H(f)`` of the complex drive envelope
        at the frequencies ``f`` (Hz), in the order they apply."""
        out = [e.drive_filter(self.tm, v, f) for e, v in self.items]
        return [h for h in out if h is not None]

    def memories(self, f):
        """The present effects' power memories ``(gain, H(f))`` at the frequencies
        ``f`` (Hz): the field is multiplied by ``1 + gain s(t)``, ``s`` the drive power
        through ``H``."""
        out = [e.power_memory(self.tm, v, f) for e, v in self.items]
        return [m for m in out if m is not None]


class ToneModel(EnvelopeEngine):
    """Predicted tone powers of every trace of the spectra grid (both flags).

    Parameters of :meth:`P_dB` and friends are dicts: the nuisances by name,
    effect parameters as ``"<effect>.<param>"``; missing = baseline.
    """

    def __init__(self, camp: Campaign, lut_points: int | None = None):
        amp, ph = camp.amplitude, camp.phase
        self.tf = TransferFunction(amp.powers, tuple(amp.coefficients),
                                   () if ph is None else ph.powers,
                                   () if ph is None else tuple(ph.coefficients))
        pts = lut_points or int((camp.meta.get("predistortion_table") or {})
                                .get("points", ERROR_MODEL.table_points))
        target, rf, _ = predistortion_table(self.tf, pts)
        self.lut_target, self.lut_rf = target, rf
        self.A = np.asarray(camp.A_tones, dtype=float)
        self.nu, self.xi0 = camp.nu, camp.xi0_spectra
        # polynomial coefficient vectors (index = power) for direct evaluation
        self._cy = np.zeros(max(amp.powers) + 1)
        self._cy[list(amp.powers)] = amp.coefficients
        self._cp = np.zeros((max(ph.powers) + 1) if ph is not None else 1)
        if ph is not None:
            self._cp[list(ph.powers)] = ph.coefficients
        self.xg = np.linspace(0.0, 1.0, 8001)           # grid of a rebuilt table's inverse
        self.A_corr = float(self.tf.A_corr)
        self.power_scale = float(amp.power_scale)
        self._A_pmax = np.linspace(0.0, 1.0, 201)
        self.P_max = float(np.max(amp.power(self._A_pmax)))
        self.has_phase = ph is not None
        # calibration uncertainty as nuisance modes: the coefficient errors
        # delta = L z (C = L L^T, z ~ N(0, I)) rotated so that the first modes
        # move y(A) (phi(A)) most on [0, 1]; each mode has a N(0, 1) prior
        self.amp_modes = calibration_error_modes(np.asarray(amp.covariance)[1:, 1:], amp.powers[1:],
                                len(amp.powers) - 1)
        self.phase_modes = (calibration_error_modes(np.asarray(ph.covariance), ph.powers, len(ph.powers))
                            if ph is not None else np.zeros((0, 1)))
        self.drift_modes = (np.zeros((0, len(amp.powers) - 1)) if camp.drift_modes is None
                            else np.asarray(camp.drift_modes))
        self.drift_significant = int(camp.drift_significant)
        self.mode_names = ([f"cal_amp{i}" for i in range(len(self.amp_modes))]
                           + [f"cal_phase{i}" for i in range(len(self.phase_modes))])
        #: sign with which the recorded phase response enters the field (+1: exp(+i phi))
        self.phase_sign = 1
        self._setup_envelope()
        self._td = None
        self._off_key = None

    def __getstate__(self):
        # the engines' caches (megabytes) are not part of the model: not pickled
        return {k: v for k, v in self.__dict__.items() if not k.endswith("_cache")}

    # ------------------------------------------------------------- copies
    def with_phase_sign(self, sign: int) -> "ToneModel":
        """A copy in which the recorded phase response enters as ``exp(sign i phi)``.

        The sign convention of a lab's ``phase_rad`` relative to the field at
        the ions is not fixed by the recordings: the tone powers of a memoryless
        field are the same for both signs (red and blue swap, and the Cardioid's
        spectra are red/blue symmetric), only the gates tell.
        """
        new = copy.copy(self)
        flip = int(sign) * self.phase_sign
        new._cp = flip * self._cp
        new.phase_modes = flip * self.phase_modes
        new.phase_sign = int(sign)
        new._off_key = None
        return new

    # ------------------------------------------------------------- curves
    def y_calibrated(self, a: float) -> float:
        """y(a) of the campaign's amplitude calibration (no error modes applied)."""
        return float(np.polynomial.polynomial.polyval(a, self._cy))

    def y_max(self, cy) -> float:
        """Largest field of the amplitude curve ``cy`` on 0 <= A <= 1 (P_max = its square)."""
        return float(np.max(np.polynomial.polynomial.polyval(self._A_pmax, cy)))

    def coefficients(self, p: dict):
        """The forward model's coefficient vectors ``(cy, cp)`` (index = power of the drive
        amplitude) at the parameter set ``p``: the calibration modes and the effects
        present applied."""
        return self._coefficients(p, ActiveEffects(self, p))

    def _coefficients(self, p: dict, act: ActiveEffects):
        """Forward-model coefficient vectors with the calibration modes and effects applied."""
        cy, cp = self._cy, self._cp
        na = len(self.amp_modes)
        amp_names, phase_names = self.mode_names[:na], self.mode_names[na:]
        if any(p.get(k, 0.0) for k in amp_names):
            cy = cy.copy()
            for k, m in zip(amp_names, self.amp_modes):
                cy[2:2 + m.size] += float(p.get(k, 0.0)) * m
        if any(p.get(k, 0.0) for k in phase_names):
            cp = cp.copy()
            for k, m in zip(phase_names, self.phase_modes):
                cp[1:1 + m.size] += float(p.get(k, 0.0)) * m
        if p.get("pm_x", 0.0):
            # the AOM's own AM-to-PM (a nuisance without a phase file)
            cp = np.concatenate([cp, np.zeros(max(3 - cp.size, 0))])
            cp[2] += self.phase_sign * float(p["pm_x"])
        for e, v in act.items:
            cy, cp = e.coefficients(self, v, cy, cp)
        return cy, cp

    def _table(self, act: ActiveEffects) -> np.ndarray:
        """Table (RF amplitude per target on the uniform grid) the AWG applies."""
        for e, v in act.items:
            c = e.table_curve(self, v, self._cy)
            if c is not None:
                # kept per curve: the DPD-on half of every Jacobian column but the table's
                # own asks for the same table again
                cache = self.__dict__.setdefault("_table_cache", ModelCache(shared=True))
                key = _array_key(np.asarray(c))
                table = cache.get(key)
                if table is None:
                    yt = np.polynomial.polynomial.polyval(self.xg, c)
                    # inverse by interpolation on the fine grid (monotone part), clamped to
                    # full drive as predistortion_table does for targets >= y(1)
                    top = int(np.argmax(yt))
                    inv = np.interp(self.lut_target, yt[:top + 1], self.xg[:top + 1])
                    table = cache[key] = np.where(self.lut_target >= yt[-1], 1.0, inv)
                return table
        return self.lut_rf

    def _static(self, mag, coef, act: ActiveEffects, where=None):
        """Field (complex, phase of the drive not included) of drive magnitudes ``mag``.

        On many samples (the time-domain field) the transfer is tabulated on
        ``STATIC_TABLE + 1`` magnitudes and interpolated linearly: the curves are
        smooth on [0, 1] (interpolation error ~1e-9 of the field, far below the
        weakest tone used), and a table lookup costs a fifth of evaluating them.
        ``where``: the samples' places in that table (:func:`uniform_place`) when the
        caller keeps them."""
        mag = np.asarray(mag)
        if mag.size > 8 * STATIC_TABLE:
            memo = self.__dict__.setdefault("_static_table_cache",
                                            ModelCache(STATIC_MEMO_ENTRIES, shared=True))
            grid = memo.get("grid")
            if grid is None:
                grid = memo["grid"] = np.linspace(0.0, 1.0, STATIC_TABLE + 1)
            F = self._static_memo(grid, coef, act, memo)
            if where is None:
                return uniform_interp(mag, F, F[1:] - F[:-1])
            return uniform_at(where, F, F[1:] - F[:-1])
        cy, cp = coef
        m = np.minimum(mag, 1.0)
        y = _calibrated_field(m, cy, cp)
        return self._after_static(y, m, cy, act)

    def _static_memo(self, mag, coef, act: ActiveEffects, memo):
        """:meth:`_static` of fixed magnitudes ``mag`` (the quadrature's), keeping in
        ``memo`` (a :class:`ModelCache` that belongs to these magnitudes) the parts a
        fit's Jacobian repeats: the clipped magnitudes, the amplitude curve per ``cy``,
        its phase factor per ``cp`` and their product.  The same operations on the same
        numbers as :meth:`_static`."""
        cy, cp = coef
        m = memo.get("m")
        if m is None:
            m = memo["m"] = np.minimum(mag, 1.0)
        ky, kp = _array_key(cy), _array_key(cp)
        y = memo.get(("y", ky, kp))
        if y is None:
            ya = memo.get(("amp", ky))
            if ya is None:
                ya = memo[("amp", ky)] = np.polynomial.polynomial.polyval(m, cy)
            if np.any(cp):
                ph = memo.get(("phase", kp))
                if ph is None:
                    ph = memo[("phase", kp)] = _unit_phasor(
                        np.polynomial.polynomial.polyval(m, cp))
                y = ya * ph
            else:
                y = ya.astype(complex)
            memo[("y", ky, kp)] = y
        return self._after_static(y, m, cy, act)

    def _after_static(self, y, m, cy, act: ActiveEffects):
        """The calibrated field ``y`` at clipped magnitudes ``m`` through the present
        effects' transfers and memories' steady states (a new array: ``y`` unchanged)."""
        for e, v in act.items:
            y = e.transfer(self, v, y, cy)
        for e, v, gain in act.memory_gains():
            # the calibration runs drive a constant amplitude: a memory's steady state
            # (gain 1 + c |x|^2, the kernel's H(0) = 1) is inside the measured
            # transfer, so only the dynamic part 1 + c s(t) acts beyond it
            y = y / (1 + gain * m ** 2)
        return y

    # ------------------------------------------------------------- time-domain engine
    def _time_domain(self, dpd: int):
        """The time-domain grid of a path (without or with DPD) and its frequencies."""
        if self._td is None:
            tones = cardioid()
            g0 = self._grid0
            self._td = []
            for os_ in OVERSAMPLE:
                grid = sample_grid(self.nu, self.xi0, tones, fs=g0.fs * os_,
                                   extra_harmonics=(-2, 0, 3, 5))
                self._td.append((grid, np.fft.fftfreq(grid.n_samples, 1.0 / grid.fs)))
        return self._td[int(bool(dpd))]

    def _drive_spectrum(self, A, d: int, table) -> np.ndarray:
        """FFT of the drive (DPD by ``table`` when ``d``) at amplitudes ``A`` on the
        time-domain grid, cached: a memory's fit changes only its filter."""
        grid, _ = self._time_domain(d)
        key = (tuple(np.round(A, 12)), d, id(table) if d else None)
        cache = self.__dict__.setdefault("_drive_cache", {})
        if key not in cache:
            if len(cache) > 8:
                cache.clear()
            w = synthesize(cardioid(), grid, np.asarray(A, dtype=float))
            w = w[None, :] if w.ndim == 1 else w
            x = np.sign(w) * uniform_interp(np.abs(w), table) if d else w
            cache[key] = (table, np.fft.fft(x, axis=-1))      # table kept: its id stays valid
        return cache[key][1]

    def _filtered_drive(self, A, d: int, table, H) -> dict:
        """The drive through the filter ``H`` on the time-domain grid: its magnitude
        ``mag`` and phase factor ``phase`` (``x / |x|``), cached by the filter (a fit of
        the fast memory also moves the calibration modes and nuisances, which act after
        it)."""
        A = np.ascontiguousarray(A, dtype=float)
        key = (A.tobytes(), int(bool(d)), table.tobytes() if d else None, H.tobytes())
        cache = self.__dict__.setdefault("_drive_td_cache",
                                         ModelCache(_TD_CACHE_ENTRIES, shared=True))
        out = cache.get(key)
        if out is None:
            x = np.fft.ifft(self._drive_spectrum(A, d, table) * H, axis=-1)
            mag = np.abs(x)
            out = {"mag": mag, "phase": x / np.maximum(mag, 1e-300)}
            if mag.size > 8 * STATIC_TABLE:
                out["where"] = uniform_place(mag, STATIC_TABLE)
            cache[key] = out
        return out

    def _tones_time_domain(self, A, p, act, dpd_flags, harmonics):
        coef = self._coefficients(p, act)
        table = self._table(act)
        out = []
        for d in dpd_flags:
            grid, freq = self._time_domain(d)
            kb, kr = grid.tone_bins(np.asarray(harmonics))
            H = np.ones(freq.size, dtype=complex)
            for h in act.filters(freq):
                H = H * h
            drive = self._filtered_drive(A, d, table, H)
            mag = drive["mag"]
            y = self._static(mag, coef, act, drive.get("where")) * drive["phase"]
            for e, v in act.items:
                mem = e.power_memory(self, v, freq)
                if mem is not None:
                    if "power_fft" not in drive:
                        drive["power_fft"] = np.fft.fft(np.minimum(mag, 1.0) ** 2, axis=-1)
                    s = np.fft.ifft(drive["power_fft"] * mem[1], axis=-1).real
                    y = y * (1 + mem[0] * s)
            spec = np.fft.fft(y, axis=-1) / grid.n_samples
            out.append(np.stack([spec[:, kr], spec[:, kb]], axis=1))
        return np.stack(out, axis=1)

    # ------------------------------------------------------------- public
    def drive_field(self, x, freq, p: dict) -> np.ndarray:
        """The optical field of a complex drive ``x`` (one period; ``freq`` its FFT
        frequencies, Hz) at the parameter set ``p``: the present effects' drive filters,
        the calibrated static transfer with the effects' transfers, their power memories
        -- what the time-domain engine does to the gate waveform, for another drive (the
        AOM pulse response's step, :mod:`~dpdfit.analyses.diagnosis.model.pulse_block`)."""
        act = ActiveEffects(self, p)
        x = np.asarray(x, dtype=complex)
        filters = act.filters(freq)
        if filters:
            x = np.fft.ifft(np.fft.fft(x) * np.prod(filters, axis=0))
        mag = np.abs(x)
        y = self._static(mag, self._coefficients(p, act), act) * (x / np.maximum(mag, 1e-300))
        memories = act.memories(freq)
        if memories:
            power_fft = np.fft.fft(np.minimum(mag, 1.0) ** 2)
            for gain, H in memories:
                y = y * (1 + gain * np.fft.ifft(power_fft * H).real)
        return y

    def tone_amplitudes(self, A, p: dict, harmonics=TONE_HARMONICS, dpd_flags=(0, 1)):
        """Complex tone amplitudes at drive amplitudes ``A``: shape (len(A), len(dpd_flags),
        2 sideband [red, blue], len(harmonics)); the field's Fourier coefficients at
        ``-(nu + n xi0)`` (red) and ``+(nu + n xi0)`` (blue)."""
        act = ActiveEffects(self, p)
        A = np.atleast_1d(np.asarray(A, dtype=float))
        if act.filters(np.zeros(1)):
            return self._tones_time_domain(A, p, act, dpd_flags, harmonics)
        return self._tones_envelope(A, p, act, dpd_flags, harmonics)

    def P_dB(self, p: dict) -> np.ndarray:
        """Tone powers, shape (nA, 2 dpd, 2 sideband [red, blue], len(TONE_HARMONICS))."""
        # the DPD-off half does not depend on parameters that move the table only:
        # cached on the others, it halves the stale table's evaluations
        table_only = {e.key(k) for e in EFFECTS.values() for k in e.table_only}
        key = tuple(sorted((k, float(v)) for k, v in p.items() if k not in table_only))
        if self._off_key != key:
            self._off_key = key
            self._off_P = _dB(self.tone_amplitudes(self.A, p, dpd_flags=(0,)))[:, 0]
        on = _dB(self.tone_amplitudes(self.A, p, dpd_flags=(1,)))[:, 0]
        return np.stack([self._off_P, on], axis=1)

    def tone_powers_at(self, A, p: dict) -> np.ndarray:
        """Tone powers (dB) of the gate waveform at amplitudes ``A`` for parameters ``p``:
        shape (len(A), 2 dpd, 2 sideband, len(TONE_HARMONICS))."""
        return _dB(self.tone_amplitudes(A, p))

    def features(self, p: dict) -> dict:
        """The model's per-trace tone features at the parameter set ``p``, ``{name:
        array}`` (:func:`~dpdfit.analyses.diagnosis.observables.tone_features.tone_features`, values only).

        The last few parameter sets' features are kept (read-only arrays): a fit evaluates
        some points again (its start for the modes' linearisation and again for the
        solver, the profiled modes and the result at its optimum)."""
        key = tuple(sorted((k, float(v)) for k, v in p.items()))
        cache = self.__dict__.setdefault("_features_cache", ModelCache(shared=True))
        out = cache.get(key)
        if out is None:
            P = self.P_dB(p)
            out = cache[key] = {k: v for k, (v, _) in tone_features(P, self.A).items()}
        return out

    def gate_tones(self, p: dict, A: float, dpd: int, harmonics=GATE_HARMONICS):
        """Engine-convention tone amplitudes (n, b, c) of the gate waveform at ``A``."""
        t = self.tone_amplitudes([A], p, harmonics, dpd_flags=(int(dpd),))[0, 0]
        n = np.asarray(harmonics)
        b, c = gate_sim.field_amplitudes(t[1], t[0])
        return n, b, c


def _calibrated_field(m: np.ndarray, cy: np.ndarray, cp: np.ndarray) -> np.ndarray:
    """The calibrated transfer ``y(m) exp(i phi(m))`` (complex) at clipped magnitudes ``m``."""
    y = np.polynomial.polynomial.polyval(m, cy)
    if np.any(cp):
        return y * _unit_phasor(np.polynomial.polynomial.polyval(m, cp))
    return y.astype(complex)


def _array_key(a: np.ndarray) -> tuple:
    """A hashable key of an array's exact values."""
    return a.dtype.str, a.shape, a.tobytes()


def _unit_phasor(phi: np.ndarray) -> np.ndarray:
    """``exp(i phi)`` of real ``phi`` as ``cos phi + i sin phi`` (numpy's complex exponential
    of a purely imaginary argument gives these values, more slowly)."""
    out = np.empty(np.shape(phi), dtype=complex)
    np.cos(phi, out=out.real)
    np.sin(phi, out=out.imag)
    return out


def _dB(a: np.ndarray) -> np.ndarray:
    return 10 * np.log10(np.maximum(np.abs(a) ** 2, 1e-300))


def calibration_error_modes(cov, powers, k):
    """Coefficient directions of the ``k`` largest function-space error modes (1 sigma each)."""
    cov = np.asarray(cov, dtype=float)
    n = cov.shape[0]
    if n == 0 or k == 0 or not np.all(np.isfinite(cov)):
        return np.zeros((0, n))
    w, U = np.linalg.eigh(0.5 * (cov + cov.T))
    L = U * np.sqrt(np.clip(w, 0, None))                    # cov = L L^T
    A = np.linspace(0.0, 1.0, 101)
    V = A[:, None] ** np.asarray(powers, dtype=float)[None, :]
    _, sv, Vt = np.linalg.svd(V @ L, full_matrices=False)
    return np.array([L @ Vt[i] for i in range(min(k, n))])
