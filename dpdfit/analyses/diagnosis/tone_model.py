"""The forward model of a campaign's tone powers (the tone side of the diagnosis, issue #7).

The *baseline* model is the simulation built from the campaign's own
calibration: the AM/PM polynomials of the model runs, the predistortion table
computed from the amplitude run that ``campaign.json`` names (4096 points,
linear interpolation, as the AWG applies it) and the Cardioid(1,2) waveform;
the gates' forward model is :mod:`dpdfit.analyses.diagnosis.gate_model`.  Its
existing parameters, refitted first, are the calibration's largest error modes
(``cal_amp*``, ``cal_phase*``: directions of the fit covariance that move
y(A), phi(A) most, N(0, 1) priors, forward model only).

The tone-side effects of the catalog (:mod:`dpdfit.analyses.diagnosis.effects`)
enter :meth:`ToneModel.field` by their parameters' names:

* ``am_pm_omitted`` -- extra AM-to-PM, ``exp(i dphi r^2)``, ``r = |y|/y(1)``
  (variant: ``dphi_x |x|^2`` of the RF drive, in the phase polynomial);
* ``aom_memory`` -- single-pole response of the modulator to its drive
  envelope, ``H(f) = 1/(1 + i 2 pi (f - f_off) tau)``, before the static
  transfer (Wiener model) (variant: the slow, thermal gain change
  ``(th_a + i th_p) s(t)``);
* ``stale_calibration`` -- the table is rebuilt from the calibration moved
  along its error modes ``st*`` (variant: today's transfer moved along the
  run-to-run drift modes ``sa*``);
* ``higher_order_im`` -- fifth-order field distortion ``y (1 + k5 r^4)``;
* ``detector_nonlinearity`` -- the calibration photodiode read
  ``P (1 + k (P/P_max)^q)``: the true transfer is the corrected one while the
  table was built from the distorted one.
"""

from __future__ import annotations

import numpy as np

from dpdfit.models import gate_sim
from dpdfit.analyses.diagnosis.observables import TONE_HARMONICS, Campaign, tone_features
from dpdfit.models.transfer import TransferFunction, predistortion_table
from dpdfit.models.waveforms import cardioid, sample_grid, synthesize

__all__ = ["ToneModel", "OVERSAMPLE", "N_AMP_MODES", "N_PHASE_MODES", "NEWTON_DET"]


def _uniform_interp(x, table):
    """Linear interpolation in a table on the uniform grid 0..1 (as the AWG applies it).

    Hand-written because ``np.interp`` bisects for every sample; on a uniform
    grid the index is arithmetic (5-10x faster on the model's ~10^5 samples).
    """
    n = table.size - 1
    u = np.clip(x, 0.0, 1.0) * n
    i = np.minimum(u.astype(np.intp), n - 1)
    f = u - i
    return table[i] + f * (table[i + 1] - table[i])


#: Newton steps of the detector model's inversion for exponents q != 1
NEWTON_DET = 5
#: oversampling of the tone model's grid beyond the single-nonlinearity no-alias rate
OVERSAMPLE = 4
#: calibration-uncertainty modes refitted as nuisances (amplitude, phase): all of them
#: (K = 8 with unit slope: 7; K = 5 through the origin: 5); the diagnosis profiles them
#: out linearly, so they cost no Jacobian columns
N_AMP_MODES = 7
N_PHASE_MODES = 5


def _modes(cov, powers, k):
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


class ToneModel:
    """Predicted tone powers of every trace of the spectra grid (both flags).

    The field is computed on the exact no-alias grid of :mod:`dpdfit.models.waveforms`
    (one gate period), so each tone falls on one FFT bin.
    """

    def __init__(self, camp: Campaign, lut_points: int | None = None):
        amp, ph = camp.amplitude, camp.phase
        self.tf = TransferFunction(amp.powers, tuple(amp.coefficients),
                                   () if ph is None else ph.powers,
                                   () if ph is None else tuple(ph.coefficients))
        pts = lut_points or int((camp.meta.get("predistortion_table") or {}).get("points", 4096))
        target, rf, _ = predistortion_table(self.tf, pts)
        self.lut_target, self.lut_rf = target, rf
        self.A = camp.A_tones
        tones = cardioid()
        g0 = sample_grid(camp.nu, camp.xi0_spectra, tones, extra_harmonics=(-2, 0, 3, 5))
        # oversampled: predistortion, memory and the static transfer compose to
        # products beyond the order-9 no-alias bound of a single nonlinearity
        self.grid = sample_grid(camp.nu, camp.xi0_spectra, tones, fs=g0.fs * OVERSAMPLE,
                                extra_harmonics=(-2, 0, 3, 5))
        self.w = synthesize(tones, self.grid, self.A)                 # (nA, N) real
        self.freq = np.fft.fftfreq(self.grid.n_samples, 1.0 / self.grid.fs)
        kb, kr = self.grid.tone_bins(TONE_HARMONICS)
        self.kb, self.kr = kb, kr
        # static transfer on a fine grid (linear interpolation error < 1e-8)
        # polynomial coefficient vectors (index = power) for direct evaluation
        self._cy = np.zeros(max(amp.powers) + 1)
        self._cy[list(amp.powers)] = amp.coefficients
        self._cp = np.zeros((max(ph.powers) + 1) if ph is not None else 1)
        if ph is not None:
            self._cp[list(ph.powers)] = ph.coefficients
        self.xg = np.linspace(0.0, 1.0, 8001)           # grid of the stale table's inverse
        self.A_corr = float(self.tf.A_corr)
        self.power_scale = float(amp.power_scale)
        self.P_max = float(np.max(amp.power(np.linspace(0, 1, 201))))
        self._A_pmax = np.linspace(0.0, 1.0, 201)
        self.has_phase = ph is not None
        # calibration uncertainty as nuisance modes: the coefficient errors
        # delta = L z (C = L L^T, z ~ N(0, I)) rotated so that the first modes
        # move y(A) (phi(A)) most on [0, 1]; each mode has a N(0, 1) prior
        self.amp_modes = _modes(np.asarray(amp.covariance)[1:, 1:], amp.powers[1:],
                                N_AMP_MODES)
        self.phase_modes = (_modes(np.asarray(ph.covariance), ph.powers, N_PHASE_MODES)
                            if ph is not None else np.zeros((0, 1)))
        self.stale_modes = _modes(np.asarray(amp.covariance)[1:, 1:], amp.powers[1:], 7)
        self.drift_modes = (np.zeros((0, len(amp.powers) - 1)) if camp.drift_modes is None
                            else np.asarray(camp.drift_modes))
        self.mode_names = ([f"cal_amp{i}" for i in range(len(self.amp_modes))]
                           + [f"cal_phase{i}" for i in range(len(self.phase_modes))])
        #: sign with which the recorded phase response enters the field (+1: exp(+i phi))
        self.phase_sign = 1

    def with_phase_sign(self, sign: int) -> "ToneModel":
        """A copy in which the recorded phase response enters as ``exp(sign i phi)``.

        The sign convention of a lab's ``phase_rad`` relative to the field at
        the ions (heterodyne reference above or below, engineering or physics
        time convention) is not fixed by the recordings: the tone powers are
        exactly the same for both signs (red and blue swap, and the
        Cardioid's spectra are red/blue symmetric), only the gates tell.
        """
        import copy
        new = copy.copy(self)
        flip = int(sign) * self.phase_sign
        new._cp = flip * self._cp
        new.phase_modes = flip * self.phase_modes
        new.phase_sign = int(sign)
        new._off_key = None
        return new

    def y_calibrated(self, a: float) -> float:
        """y(a) of the campaign's amplitude calibration (no error modes applied)."""
        return float(np.polynomial.polynomial.polyval(a, self._cy))

    def stale_dc(self, p: dict) -> np.ndarray:
        """Coefficient changes dc_k (k = 2..8) of the stale table's calibration."""
        v = np.array([float(p.get(f"st{i}", 0.0)) for i in range(len(self.stale_modes))])
        return v @ self.stale_modes if v.size else np.zeros(0)

    def _coefficients(self, p: dict):
        """Forward-model coefficient vectors with the calibration modes applied."""
        cy, cp = self._cy, self._cp
        if any(p.get(f"cal_amp{i}", 0.0) for i in range(len(self.amp_modes))):
            cy = cy.copy()
            for i, m in enumerate(self.amp_modes):
                cy[2:2 + m.size] += float(p.get(f"cal_amp{i}", 0.0)) * m
        if any(p.get(f"sa{i}", 0.0) for i in range(len(self.drift_modes))):
            cy = cy.copy()
            for i, m in enumerate(self.drift_modes):
                cy[2:2 + m.size] += float(p.get(f"sa{i}", 0.0)) * m
        if any(p.get(f"cal_phase{i}", 0.0) for i in range(len(self.phase_modes))):
            cp = cp.copy()
            for i, m in enumerate(self.phase_modes):
                cp[1:1 + m.size] += float(p.get(f"cal_phase{i}", 0.0)) * m
        if p.get("dphi_x", 0.0):
            cp = np.concatenate([cp, np.zeros(max(3 - cp.size, 0))])
            cp[2] += float(p["dphi_x"])
        return cy, cp

    def _y_max(self, cy) -> float:
        """Largest field of the amplitude curve ``cy`` on 0 <= A <= 1 (P_max = its square)."""
        return float(np.max(np.polynomial.polynomial.polyval(self._A_pmax, cy)))

    def _static(self, x, k_det, coef, q_det=1.0):
        cy, cp = coef
        mag = np.minimum(np.abs(x), 1.0)
        y = np.polynomial.polynomial.polyval(mag, cy)
        if k_det:
            # calibration read u_meas = u (1 + k u), u = P/P_max: the true u solves it,
            # u_true / u = 2 / (1 + sqrt(1 + 4 k u)) (the rationalised root: no
            # cancellation as k -> 0, where finite differences of the fit probe it).
            # P/P_max of *this* curve (calibration modes applied): a scale frozen at
            # the fitted curve would move k_det with every mode that moves y(1)
            u = (y / self._y_max(cy)) ** 2
            ratio = 2.0 / (1.0 + np.sqrt(np.maximum(1 + 4 * k_det * u, 0.0)))
            if q_det != 1.0:
                # u_meas = u_t (1 + k u_t^q): Newton from the q = 1 root (a fixed number of
                # steps keeps the model smooth in k and q for the fits' differences)
                um = np.maximum(u, 1e-300)
                ut = ratio * um
                for _ in range(NEWTON_DET):
                    ut = np.maximum(ut - (ut + k_det * ut ** (q_det + 1) - um)
                                    / (1 + k_det * (q_det + 1) * ut ** q_det), 0.0)
                ratio = ut / um
            y = y * np.sqrt(ratio)
        if not np.any(cp):
            return y * np.exp(1j * np.angle(x))
        phi = np.polynomial.polynomial.polyval(mag, cp)
        return y * np.exp(1j * (np.angle(x) + phi))

    def field(self, p: dict) -> np.ndarray:
        """Complex field, shape (nA, 2 dpd, N), for parameters ``p`` (missing = baseline)."""
        return self._field(self.w, p)

    def _field(self, w: np.ndarray, p: dict) -> np.ndarray:
        """Field for waveforms ``w`` (shape (m, N)) without and with DPD: (m, 2, N)."""
        x1 = np.sign(w) * _uniform_interp(np.abs(w), self._stale_table(p))
        return np.stack([self._path(w, p), self._path(x1, p)], axis=1)

    def _path(self, x: np.ndarray, p: dict) -> np.ndarray:
        """Field of RF envelopes ``x`` (shape (m, N)): memory, static transfer, post-distortion."""
        x = x.astype(complex)
        tau = float(p.get("tau", 0.0)) * 1e-9
        if tau > 0:
            H = 1.0 / (1.0 + 2j * np.pi * (self.freq - float(p.get("f_off", 0.0)) * 1e6) * tau)
            x = np.fft.ifft(np.fft.fft(x, axis=-1) * H, axis=-1)
        y = self._static(x, float(p.get("k_det", 0.0)), self._coefficients(p),
                         float(p.get("q_det", 1.0)))
        dphi, k5 = float(p.get("dphi", 0.0)), float(p.get("k5", 0.0))
        if dphi or k5:
            # r = |y| / y(1) of the forward curve in use (calibration modes applied),
            # not of the fitted one: the physical full-drive field sets the scale
            cy = self._coefficients(p)[0]
            r2 = (np.abs(y) / np.polynomial.polynomial.polyval(1.0, cy)) ** 2
            y = y * (1 + k5 * r2 ** 2) * np.exp(1j * dphi * r2)
        th_a, th_p = float(p.get("th_a", 0.0)), float(p.get("th_p", 0.0))
        if th_a or th_p:
            # slow (thermal) memory: a complex gain change driven by the drive power
            # |x|^2 through a single-pole response of time constant th_tau (us)
            t = max(float(p.get("th_tau", 0.0)), 0.0) * 1e-6
            u = np.abs(x) ** 2
            if t > 0:
                u = np.fft.ifft(np.fft.fft(u, axis=-1) / (1.0 + 2j * np.pi * self.freq * t),
                                axis=-1)
            y = y * (1 + (th_a + 1j * th_p) * u)
        return y

    def _stale_table(self, p: dict) -> np.ndarray:
        """Table (RF amplitude per target on the uniform grid) of the table's calibration."""
        if "st0" not in p:
            return self.lut_rf
        # rebuilt even at st = 0, so the model is smooth in st for the Jacobian
        dc = self.stale_dc(p)
        c = self._cy.copy()
        c[2:2 + dc.size] += dc
        yt = np.polynomial.polynomial.polyval(self.xg, c)
        # inverse by interpolation on the fine grid (monotone part), clamped to full drive
        top = int(np.argmax(yt))
        inv = np.interp(self.lut_target, yt[:top + 1], self.xg[:top + 1])
        # as predistortion_table: targets at or above y(1) = A_corr drive full scale
        return np.where(self.lut_target >= yt[-1], 1.0, inv)

    def P_dB(self, p: dict) -> np.ndarray:
        """Tone powers, shape (nA, 2 dpd, 2 sideband [red, blue], len(TONE_HARMONICS))."""
        # the DPD-off half does not depend on the table (stale_calibration's st*):
        # cached on the other parameters, it halves the stale fit's evaluations
        key = tuple(sorted((k, float(v)) for k, v in p.items() if not k.startswith("st")))
        if getattr(self, "_off_key", None) != key:
            self._off_key, self._off_P = key, self._tone_dB(self._path(self.w, p))
        x1 = np.sign(self.w) * _uniform_interp(np.abs(self.w), self._stale_table(p))
        return np.stack([self._off_P, self._tone_dB(self._path(x1, p))], axis=1)

    def _tone_dB(self, y: np.ndarray) -> np.ndarray:
        """Tone powers (dB) of fields ``y`` (m, N): shape (m, 2 sideband, len(TONE_HARMONICS))."""
        spec = np.fft.fft(y, axis=-1) / self.grid.n_samples
        P = np.stack([np.abs(spec[..., self.kr]) ** 2, np.abs(spec[..., self.kb]) ** 2], axis=1)
        return 10 * np.log10(np.maximum(P, 1e-300))

    def tone_powers_at(self, A, p: dict) -> np.ndarray:
        """Tone powers (dB) of the gate waveform at amplitudes ``A`` for parameters ``p``:
        shape (len(A), 2 dpd, 2 sideband, len(TONE_HARMONICS))."""
        y = self._field(synthesize(cardioid(), self.grid, np.asarray(A, dtype=float)), p)
        return np.stack([self._tone_dB(y[:, d]) for d in (0, 1)], axis=1)

    def features(self, p: dict) -> dict:
        return {k: v for k, (v, _) in tone_features(self.P_dB(p), self.A).items()}

    def gate_tones(self, p: dict, A: float, dpd: int, harmonics=tuple(range(-2, 6))):
        """Engine-convention tone amplitudes (n, b, c) of the gate waveform at ``A``."""
        i = int(np.argmin(np.abs(self.A - A)))
        w = (self.w[i:i + 1] if abs(self.A[i] - A) <= 1e-9
             else synthesize(cardioid(), self.grid, np.array([A])))
        y = self._field(w, p)[0, dpd]
        spec = np.fft.fft(y) / self.grid.n_samples
        n = np.asarray(harmonics)
        kb, kr = self.grid.tone_bins(n)
        b, c = gate_sim.field_amplitudes(spec[kb], spec[kr])
        return n, b, c
