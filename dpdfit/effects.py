"""The forward model of a campaign's observables and the catalog of candidate effects (issue #7).

The *baseline* model is the simulation built from the campaign's own
calibration: the AM/PM polynomials of the model runs, the predistortion table
computed from the amplitude run that ``campaign.json`` names (4096 points,
linear interpolation, as the AWG applies it), the Cardioid(1,2) waveform, and
for the gates the exact two-ion engine (:mod:`dpdfit.gate_sim`) with the lab's
error model (``campaign.json`` ``error_model``).  Its existing parameters,
refitted first, are the calibration's largest error modes (``cal_amp*``,
``cal_phase*``: directions of the fit covariance that move y(A), phi(A) most,
N(0, 1) priors, forward model only) and each time scan's gate-rate error
(``eps_ts*``); see :data:`NUISANCES`.

Each catalog effect is a named extension with physical parameters, units and
bounds (flat priors inside them); ``EFFECTS`` lists them.  Tone-side effects
change the field the waveform produces:

* ``am_pm_omitted`` -- extra AM-to-PM, ``exp(i dphi r^2)``, ``r = |y|/y(1)``;
* ``aom_memory`` -- single-pole response of the modulator to its drive
  envelope, ``H(f) = 1/(1 + i 2 pi (f - f_off) tau)``, before the static
  transfer (Wiener model); ``f_off != 0`` makes red and blue differ;
* ``stale_calibration`` -- the table belongs to an earlier calibration whose
  order-8 polynomial is free (``a_k + dc_k``, unit slope kept: a drifted AOM
  *and* that run's own fit errors), parametrised by the calibration's 7 error
  modes; reported as ``drift``, the table calibration's fractional difference
  of y(0.5) (mid gate range: the spectra constrain it, unlike y(1)).  The forward model (today's AOM) is
  unchanged, so only the DPD flag is affected;
* ``higher_order_im`` -- fifth-order field distortion ``y (1 + k5 r^4)``
  beyond the calibrated transfer (IM5 and up);
* ``detector_nonlinearity`` -- the calibration photodiode read
  ``P (1 + k P/P_max)``: the true transfer is the corrected one while the
  table was built from the distorted one.

Gate-side effects change the gate observables through the engine's linear
response (computed once per campaign by engine finite differences at every
gate setting and at the time-scan settings' scan times): ``dephasing`` (extra rate, 1/s),
``motional_heating`` (quanta/ms), ``spam_offset`` (extra preparation error per
ion), ``gate_rate_miscalibration`` (optical power offset at gate time, dB;
its response is quadratic and includes the lab's known per-scan jitter and
gate-rate calibration error), ``higher_nbar`` (extra initial phonons).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import gate_sim
from .observables import HARMONICS, Campaign, tone_features
from .transfer import TransferFunction, predistortion_table
from .waveforms import cardioid, sample_grid, synthesize

__all__ = ["Param", "Effect", "EFFECTS", "NUISANCES", "ToneModel", "GateModel"]


@dataclass(frozen=True)
class Param:
    """One physical parameter: name, unit, bounds (flat prior inside), start, step."""

    name: str
    unit: str
    lo: float
    hi: float
    start: float
    scale: float


@dataclass(frozen=True)
class Effect:
    """A named extension of the forward model."""

    name: str
    side: str                    # "tones" or "gates"
    params: tuple
    meaning: str


EFFECTS = {e.name: e for e in (
    Effect("am_pm_omitted", "tones",
           (Param("dphi", "rad", -1.0, 1.0, 0.0, 0.05),),
           "AM-to-PM conversion left out of the model (phase at full drive ~ |y|^2)"),
    Effect("aom_memory", "tones",
           (Param("tau", "ns", 0.0, 400.0, 30.0, 20.0),
            Param("f_off", "MHz", -20.0, 20.0, 0.0, 1.0)),
           "finite response time of the modulator to its drive envelope (single pole)"),
    Effect("stale_calibration", "tones",
           tuple(Param(f"st{i}", "sigma", -60.0, 60.0, 0.0, 1.0) for i in range(7)),
           "predistortion table from an earlier calibration: its amplitude polynomial "
           "a_k + dc_k (k = 2..8, a_1 = 1) is free, parametrised by the calibration's 7 "
           "error modes (st_i, in units of their sigma); reported as drift = the table "
           "calibration's fractional difference of y(0.5)"),
    Effect("higher_order_im", "tones",
           (Param("k5", "1", -0.5, 0.5, 0.0, 0.01),),
           "fifth-order field distortion beyond the calibrated transfer (IM5 and up)"),
    Effect("detector_nonlinearity", "tones",
           (Param("k_det", "1/P_max", -0.5, 0.5, 0.0, 0.02),),
           "calibration photodiode response P (1 + k P/P_max)"),
    Effect("dephasing", "gates",
           (Param("gamma", "1/s", 0.0, 2000.0, 10.0, 20.0),),
           "extra qubit dephasing rate (loss grows with gate time)"),
    Effect("motional_heating", "gates",
           (Param("ndot", "quanta/ms", 0.0, 5.0, 0.01, 0.05),),
           "extra heating of the gate mode"),
    Effect("spam_offset", "gates",
           (Param("p_prep", "probability", 0.0, 0.2, 0.001, 0.005),),
           "extra state-preparation error per ion (constant offset)"),
    Effect("gate_rate_miscalibration", "gates",
           (Param("eps", "dB", -3.0, 3.0, 0.0, 0.1),),
           "optical power at gate time differs from the gate-rate calibration"),
    Effect("higher_nbar", "gates",
           (Param("dnbar", "quanta", 0.0, 5.0, 0.05, 0.1),),
           "higher initial mean phonon number"),
)}

#: existing parameters of the model, refitted first: name -> (unit, meaning)
NUISANCES = {"cal_amp0..3": ("sigma", "largest error modes of the amplitude calibration "
                                        "(forward model only; prior N(0, 1))"),
             "cal_phase0..1": ("sigma", "largest error modes of the phase calibration"),
             "eps_ts*": ("dB", "each time scan's gate-rate error (prior: rate calibration)"),
             "gate_power_offset": ("dB", "absolute scale of the heterodyne tone powers")}


# --------------------------------------------------------------------------- tones


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

    The field is computed on the exact no-alias grid of :mod:`dpdfit.waveforms`
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
        kb, kr = self.grid.tone_bins(HARMONICS)
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
        self.mode_names = ([f"cal_amp{i}" for i in range(len(self.amp_modes))]
                           + [f"cal_phase{i}" for i in range(len(self.phase_modes))])

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
        if any(p.get(f"cal_phase{i}", 0.0) for i in range(len(self.phase_modes))):
            cp = cp.copy()
            for i, m in enumerate(self.phase_modes):
                cp[1:1 + m.size] += float(p.get(f"cal_phase{i}", 0.0)) * m
        return cy, cp

    def _y_max(self, cy) -> float:
        """Largest field of the amplitude curve ``cy`` on 0 <= A <= 1 (P_max = its square)."""
        return float(np.max(np.polynomial.polynomial.polyval(self._A_pmax, cy)))

    def _static(self, x, k_det, coef):
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
            y = y * np.sqrt(2.0 / (1.0 + np.sqrt(np.maximum(1 + 4 * k_det * u, 0.0))))
        if not self.has_phase:
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
        y = self._static(x, float(p.get("k_det", 0.0)), self._coefficients(p))
        dphi, k5 = float(p.get("dphi", 0.0)), float(p.get("k5", 0.0))
        if dphi or k5:
            # r = |y| / y(1) of the forward curve in use (calibration modes applied),
            # not of the fitted one: the physical full-drive field sets the scale
            cy = self._coefficients(p)[0]
            r2 = (np.abs(y) / np.polynomial.polynomial.polyval(1.0, cy)) ** 2
            y = y * (1 + k5 * r2 ** 2) * np.exp(1j * dphi * r2)
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
        """Tone powers, shape (nA, 2 dpd, 2 sideband [red, blue], len(HARMONICS))."""
        # the DPD-off half does not depend on the table (stale_calibration's st*):
        # cached on the other parameters, it halves the stale fit's evaluations
        key = tuple(sorted((k, float(v)) for k, v in p.items() if not k.startswith("st")))
        if getattr(self, "_off_key", None) != key:
            self._off_key, self._off_P = key, self._tone_dB(self._path(self.w, p))
        x1 = np.sign(self.w) * _uniform_interp(np.abs(self.w), self._stale_table(p))
        return np.stack([self._off_P, self._tone_dB(self._path(x1, p))], axis=1)

    def _tone_dB(self, y: np.ndarray) -> np.ndarray:
        """Tone powers (dB) of fields ``y`` (m, N): shape (m, 2 sideband, len(HARMONICS))."""
        spec = np.fft.fft(y, axis=-1) / self.grid.n_samples
        P = np.stack([np.abs(spec[..., self.kr]) ** 2, np.abs(spec[..., self.kb]) ** 2], axis=1)
        return 10 * np.log10(np.maximum(P, 1e-300))

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


# --------------------------------------------------------------------------- gates

#: finite-difference steps of the gate-side responses
_STEPS = {"gamma": 100.0, "ndot": 0.1, "p_prep": 0.01, "eps": 0.3, "dnbar": 0.2}
#: engine tolerances for the diagnosis (probabilities to ~1e-6, far below shot noise)
_TOL = {"rtol": 1e-7, "atol": 1e-9}
_LINEAR = ("gamma", "ndot", "p_prep", "dnbar")
_XI_STEP = 0.01


class GateModel:
    """Gate observables under the lab's error model and their response to gate-side effects.

    Baseline values per setting come from the engine (nominal error model, no
    power error), with each setting's ``eta Omega0`` chosen so that the
    engine's gate rate equals the recorded ``xi0`` (the lab's calibration).
    Responses to the effect parameters are finite differences of the engine at
    each setting (its own tones and rate) and, for the time scans, at every
    scan time.  The power error's response is quadratic (``lin eps + quad
    eps^2``); the known random power errors (per-scan jitter, per-setting
    gate-rate error) add ``quad * var`` to the expected values and a shared,
    linearised error to the variances and covariances of one setting's
    observables (:meth:`predict`).
    """

    def __init__(self, camp: Campaign, tone: ToneModel):
        em = camp.error_model
        self.em = em
        self.nominal = dict(nbar=float(em["nbar"]), T2=float(em["T2_s"]),
                            ndot=float(em["heating_quanta_per_s"]), p_prep=float(em["p_prep"]),
                            p_det=float(em["p_det"]))
        g = camp.gates
        self.gates = g
        self.ts = camp.time_scans
        base_p = {}
        self._tones, self.base = self._settings(tone, base_p)
        # each setting's own responses to the effects (engine finite differences at
        # its tones and rate): the power response of C differs in sign between
        # A = 0.6 and 0.8, so responses scaled from the time-scan setting bias eps
        self.set_ref = {}
        for r in g.itertuples():
            key = (r.A, r.dpd)
            out = {"base": self.base[key],
                   "eps+": self._run(key, r.xi0_hz, {"power_error_db": _STEPS["eps"]}, None),
                   "eps-": self._run(key, r.xi0_hz, {"power_error_db": -_STEPS["eps"]}, None)}
            for name in _LINEAR:
                out[name] = self._run(key, r.xi0_hz, self._perturb(name, _STEPS[name]), None)
            self.set_ref[key] = out
        # responses at the time-scan settings (or the first setting if none)
        ref = (list(self.ts.groupby(["A", "dpd"]).groups) if self.ts is not None
               else [(g.A.iloc[0], int(g.dpd.iloc[0]))])
        self.ref = {}
        for (A, d) in ref:
            key = (float(A), int(d))
            if key not in self._tones:
                n, b, c = tone.gate_tones(base_p, A, d)
                xi = float(g.xi0_hz.iloc[0])
                self._tones[key] = (n, b, c, xi / gate_sim.calibrate_xi0(b, c, n, 1.0))
            n, b, c, eO = self._tones[key]
            row = g[np.isclose(g.A, A) & (g.dpd == d)]
            xi = float(row.xi0_hz.iloc[0]) if len(row) else eO * gate_sim.calibrate_xi0(
                b, c, n, 1.0)
            times = self._scan_times(key)
            out = {"T": 1.0 / xi, "base": self._run(key, xi, {}, times)}
            for name, step in _STEPS.items():
                if name == "eps":
                    out["eps+"] = self._run(key, xi, {"power_error_db": step}, times)
                    out["eps-"] = self._run(key, xi, {"power_error_db": -step}, times)
                else:
                    out[name] = self._run(key, xi, self._perturb(name, step), times)
            # a gate-rate calibration error: tones at xi (1 + e) with the power for xi
            out["xi+"] = self._run(key, xi * (1 + _XI_STEP), {}, None)
            self.ref[key] = out
        self.sig_jit = float(em["power_jitter_db"])
        # power error (dB) equivalent to a relative gate-rate error, from the imbalance
        ks = []
        for ref in self.ref.values():
            lin = (ref["eps+"]["imb"] - ref["eps-"]["imb"]) / (2 * _STEPS["eps"])
            ks.append((ref["xi+"]["imb"] - ref["base"]["imb"]) / _XI_STEP / lin)
        self.db_per_rel_xi = float(np.mean(np.abs(ks)))

    def rebased(self, tone: ToneModel, p: dict) -> "GateModel":
        """A copy whose baseline values use the field of tone-side parameters ``p``.

        The settings' spectra (and so the engine's baseline values, gate
        ends and time scans) follow a tone-side effect such as AOM memory;
        the linear responses to gate-side effects are kept.
        """
        import copy
        new = copy.copy(self)
        tones, new.base = self._settings(tone, p)
        new._tones = {**self._tones, **tones}
        new.ref = {}
        for key, ref in self.ref.items():
            r2 = dict(ref)
            base = new._run(key, 1.0 / ref["T"], {}, self._scan_times(key))
            shift = {q: np.asarray(base[q]) - np.asarray(ref["base"][q]) for q in base}
            # shift every perturbed run by the same amount: responses unchanged
            for name, run in ref.items():
                if name == "T":
                    continue
                r2[name] = {q: np.asarray(run[q]) + shift[q] for q in run}
            new.ref[key] = r2
        new.set_ref = {}
        for key, ref in self.set_ref.items():
            shift = {q: new.base[key][q] - self.base[key][q] for q in self.base[key]}
            new.set_ref[key] = {name: {q: run[q] + shift[q] for q in run}
                                for name, run in ref.items()}
        new._tab = None
        return new

    def _settings(self, tone: ToneModel, p: dict):
        """Tones, ``eta Omega0`` (engine rate = recorded xi0) and baseline values per setting."""
        tones, base = {}, {}
        for r in self.gates.itertuples():
            n, b, c = tone.gate_tones(p, r.A, r.dpd)
            eO = r.xi0_hz / gate_sim.calibrate_xi0(b, c, n, 1.0)
            tones[(r.A, r.dpd)] = (n, b, c, eO)
            base[(r.A, r.dpd)] = _summary(gate_sim.simulate_setting(
                b, c, n, eO, r.xi0_hz, **self.nominal, **_TOL))
        return tones, base

    def _scan_times(self, key):
        """Scan times (s, > 0) of the time scan at setting ``key`` (None without scans)."""
        if self.ts is None:
            return None
        sel = np.isclose(self.ts.A, key[0]) & (self.ts.dpd == key[1])
        times = self.ts.loc[sel, "t_s"].to_numpy()
        return times[times > 0]

    def _perturb(self, name, step):
        nm = self.nominal
        if name == "gamma":
            return {"T2": 1.0 / (1.0 / nm["T2"] + step)}
        if name == "ndot":
            return {"ndot": nm["ndot"] + step * 1e3}
        if name == "p_prep":
            return {"p_prep": nm["p_prep"] + step}
        if name == "dnbar":
            return {"nbar": nm["nbar"] + step}
        raise KeyError(name)

    def _run(self, key, xi, kw, times):
        n, b, c, eO = self._tones[key]
        args = dict(self.nominal)
        args.update(kw)
        res = gate_sim.simulate_setting(b, c, n, eO, xi, scan_times=times, **args, **_TOL)
        s = _summary(res)
        if times is not None:
            s["P00_t"] = res.scan_pop[:, 0]
            s["P11_t"] = res.scan_pop[:, 2]
        return s

    def _resp(self, ref, q):
        """Linear responses per unit parameter at a reference: dict param -> d q."""
        out = {}
        for name, step in _STEPS.items():
            if name == "eps":
                continue
            out[name] = (np.asarray(ref[name][q]) - np.asarray(ref["base"][q])) / step
        lin = (np.asarray(ref["eps+"][q]) - np.asarray(ref["eps-"][q])) / (2 * _STEPS["eps"])
        quad = (np.asarray(ref["eps+"][q]) + np.asarray(ref["eps-"][q])
                - 2 * np.asarray(ref["base"][q])) / (2 * _STEPS["eps"] ** 2)
        return out, lin, quad

    def _tables(self):
        """Per-setting arrays of baseline values and responses (computed once)."""
        if getattr(self, "_tab", None) is not None:
            return self._tab
        g = self.gates
        tab = {}
        vj = self.sig_jit ** 2
        rel = g.xi0_rel_err.to_numpy(dtype=float)
        vx = np.where(np.isfinite(rel), (self.db_per_rel_xi * np.nan_to_num(rel)) ** 2, 0.0)
        ns = g.n_scans.to_numpy(dtype=float)
        for q in ("F_pop", "imb", "C"):
            base = np.array([self.base[(r.A, r.dpd)][q] for r in g.itertuples()])
            resp = {k: np.zeros(len(g)) for k in _LINEAR}
            lin, quad = np.zeros(len(g)), np.zeros(len(g))
            for i, r in enumerate(g.itertuples()):
                le, li, qu = self._resp(self.set_ref[(r.A, r.dpd)], q)
                for k in _LINEAR:
                    resp[k][i] = le[k]
                lin[i], quad[i] = li, qu
            tab[q] = (base, resp, lin, quad)
        tab["var"] = (vj, vx, ns)
        ts = {}
        if self.ts is not None:
            for (A, d), _ in self.ts.groupby(["A", "dpd"], sort=False):
                ref = self.ref[(float(A), int(d))]
                for q in ("P00_t", "P11_t"):
                    ts.setdefault(q, []).append(self._resp(ref, q) + (
                        np.asarray(ref["base"][q], dtype=float),))
        tab["ts"] = ts
        self._tab = tab
        return tab

    def predict(self, p: dict) -> dict:
        """Predicted gate observables and their model-side variances.

        Returns dict with arrays over the settings (order of ``camp.gates``):
        ``F_pop, imb, C``, their model-side variances ``var_*`` (known random
        power errors) and the two shared directions of those errors,
        ``dlin_*`` (``lin + 2 quad eps``, per dB) and ``dquad_*`` (``quad``),
        with weights ``v_lin`` (dB^2) and ``v_quad`` (dB^4): the three
        observables of one setting see the *same* power errors, so their
        model-side covariance is ``v_lin dlin dlin^T + v_quad dquad dquad^T``
        (linearised around ``eps``); and over
        the time-scan points (``t > 0``, concatenated over scans): ``P00_t, P11_t``.
        Time scan ``k`` also takes ``eps_ts{k}``, its own gate-rate error (dB),
        on top of ``eps``.
        """
        tab = self._tables()
        eps = float(p.get("eps", 0.0))
        vj, vx, ns = tab["var"]
        v_mean = vj / ns + vx
        v_quad = 2 * (vj ** 2 / ns + vx ** 2)
        res = {}
        for q in ("F_pop", "imb", "C"):
            base, resp, lin, quad = tab[q]
            val = base + lin * eps + quad * (eps ** 2 + vj + vx)
            for k in _LINEAR:
                val = val + resp[k] * float(p.get(k, 0.0))
            res[q] = val
            # random power error u of the setting (scan-mean jitter + rate error):
            # val(eps + u) ~ val + (lin + 2 quad eps) u + quad (u^2 - <u^2>)
            res["dlin_" + q] = lin + 2 * quad * eps
            res["dquad_" + q] = quad
            res["var_" + q] = res["dlin_" + q] ** 2 * v_mean + quad ** 2 * v_quad
        res["v_lin"], res["v_quad"] = v_mean, v_quad
        for q, parts in tab["ts"].items():
            acc = []
            for k, (le, li, qu, base) in enumerate(parts):
                e = eps + float(p.get(f"eps_ts{k}", 0.0))
                v = base + li * e + qu * e ** 2
                for name in _LINEAR:
                    v = v + le[name] * float(p.get(name, 0.0))
                acc.append(v)
            res[q] = np.concatenate(acc)
        return res

    @property
    def n_time_scans(self) -> int:
        return 0 if self.ts is None else int(self.ts.groupby(["A", "dpd"]).ngroups)

    def rate_error_db(self) -> float:
        """1-sigma power-equivalent error (dB) of one setting's gate-rate calibration."""
        rel = self.gates.xi0_rel_err.to_numpy(dtype=float)
        rel = float(np.nanmedian(rel)) if np.isfinite(rel).any() else float(
            self.em.get("xi0_rel_err", 0.01))
        return float(self.db_per_rel_xi * rel)


def _summary(res) -> dict:
    pop = res.pop
    return {"F_pop": float(pop[0] + pop[2]), "imb": float(pop[0] - pop[2]),
            "C": float(res.parity_fit()[0])}
