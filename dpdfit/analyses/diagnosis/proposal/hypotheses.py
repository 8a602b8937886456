"""A hypothesis in reach as the proposal sees it: one fit's parameter set, its tone
and gate models, its predictions of every source a recording reads (tone powers on
:data:`SPECTRA_GRID`, the gates, the next amplitude run's drift, the phase a further run records at the model's run's
amplitudes: :func:`phase_run_amplitudes`) and the parameters that can absorb a recording, with their
covariance from the recordings so far."""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.effects import effect_of_key
from dpdfit.analyses.diagnosis.fitting.fit_result import param_side
from dpdfit.analyses.diagnosis.fitting.phase_sign import tone_held
from dpdfit.analyses.diagnosis.model.gates.effect_terms import active_effects
from dpdfit.analyses.diagnosis.model.linearity_block import predicted_attenuated
from dpdfit.analyses.diagnosis.model.phase_runs_block import recorded_phase
from dpdfit.analyses.diagnosis.model.pulse_block import pulse_prediction
from dpdfit.analyses.diagnosis.model.ramsey_block import ramsey_probabilities_of
from dpdfit.analyses.diagnosis.model.runs_after import run_drift
from dpdfit.analyses.diagnosis.model.spam_block import spam_probabilities
from dpdfit.analyses.diagnosis.model.thermometry_block import thermometry_probabilities
from dpdfit.core.defaults import LINEARITY_ATTENUATION_DB, LINEARITY_POINTS, PHASE_MIN_A
from dpdfit.models.ramsey import SEQUENCES, scan_waits
from dpdfit.models.sideband_thermometry import SIDEBANDS, THERMOMETRY_WAITS_US
from dpdfit.recordings.detector_linearity import linearity_drives, transmission

__all__ = ['Hypothesis', 'SPECTRA_GRID', 'RUN_AMPLITUDES', 'SPAM_STATES', 'MODE_STEP',
           'PARAM_STEP', 'PULSE_TIMES_US', 'pulse_amplitude', 'LINEARITY_DRIVES',
           'linearity_readings', 'phase_run_amplitudes']


#: amplitudes a spectra recording may choose from
SPECTRA_GRID = np.round(np.linspace(0.05, 1.0, 20), 4)


#: amplitudes of a calibration run (the campaigns' runs: 101 points on [0, 1])
RUN_AMPLITUDES = np.linspace(0.0, 1.0, 101)


#: the basis states a SPAM characterisation prepares (``spam.csv``)
SPAM_STATES = ("00", "11")

#: the samples of an AOM pulse response (us after the step, ``pulse_response.csv``): a
#: scope trace of 4096 samples at 10 ns, the acoustic rise (tens of ns) resolved and a
#: slow memory (to 8 us) settled
PULSE_TIMES_US = np.round(np.arange(1, 4097) * 0.01, 2)


#: the drives a detector linearity characterisation reads (with and without the attenuator)
LINEARITY_DRIVES = linearity_drives(LINEARITY_POINTS)


#: finite-difference step (prior sigmas) of the calibration modes in the Jacobians
MODE_STEP = 0.05


#: finite-difference step of a fitted parameter, in units of its scale
PARAM_STEP = 1e-3


#: which parameters can move each source: the tone side's for the spectra, the phase
#: curve and the runs' drift, the gate side's for the gate recordings
_SOURCE_SIDE = {"powers": "tones", "phase": "tones", "drift": "tones", "gates": "gates",
                "spam": "gates", "pulse": "tones", "ramsey": "gates", "linearity": "tones",
                "thermometry": "gates"}


# ----------------------------------------------------------------- hypotheses
class Hypothesis:
    """One fit's parameter set, its tone model (phase-sign convention) and, on demand,
    its gate model (rebased on its field when it has tone-side effects); its
    predictions of every source at any parameter set (memoised), the parameters that
    can absorb a recording of a side and their covariance from the recordings so far.

    ``label``: the hypothesis as ``{"effects": [...], "forms": [...]}`` (what a later
    diagnosis refits to measure the separation a recording achieved).
    """

    def __init__(self, prob, fit):
        self.prob, self.fit, self.p = prob, fit, fit.all_params
        tone = getattr(prob, "tone", None)
        sign = int(fit.nuisances.get("phase_sign", 1 if tone is None else tone.phase_sign))
        self.tone = (tone if tone is None or sign == tone.phase_sign
                     else tone.with_phase_sign(sign))
        self._gate = None
        self._memo = {}
        self._mode_cov = None
        self.label = {"effects": list(fit.effects), "forms": list(fit.forms)}

    @property
    def gate(self):
        """The gate model of this hypothesis (rebased on its field when it has tone-side
        effects or another phase-sign convention), made on first use."""
        if self._gate is None:
            held = tone_held(self.prob, self.fit)
            tone_effect = any(effect_of_key(k) is not None for k in held)
            self._gate = (self.prob.gate.rebased(self.tone, held)
                          if tone_effect or self.tone is not self.prob.tone else self.prob.gate)
        return self._gate

    # ------------------------------------------------------------ predictions
    def raw(self, source: str, p: dict | None = None):
        """The prediction of ``source`` (``"powers"``: tone powers on
        :data:`SPECTRA_GRID`; ``"gates"``: the gate model's predictions; ``"drift"``: the
        next amplitude run's shift in the drift modes; ``"phase"``: the phase a further run
        records (:func:`phase_run_amplitudes`); ``"spam"``: the detected outcomes of each of
        :data:`SPAM_STATES` prepared with no gate; ``"pulse"``: the AOM pulse response at
        :data:`PULSE_TIMES_US` normalised to its settled level, :func:`pulse_amplitude`;
        ``"ramsey"``: the detected outcomes of the Ramsey sequence, then the echo, at the
        waits of :func:`~dpdfit.models.ramsey.scan_waits` for the stated T2;
        ``"linearity"``: the attenuated photodiode readings at :data:`LINEARITY_DRIVES`;
        ``"thermometry"``: the probed ion's bright probability after each wait and
        sideband of :data:`~dpdfit.models.sideband_thermometry.THERMOMETRY_WAITS_US`, red
        then blue at each) at the parameter set ``p`` (default: the fit's)."""
        p = self.p if p is None else p
        key = (source, tuple(sorted(p.items())))
        if key not in self._memo:
            self._memo[key] = _SOURCES[source](self, p)
        return self._memo[key]

    # ------------------------------------------------------------ what can absorb
    def absorbing(self, source: str) -> list:
        """``[(key, step)]``: the parameters of this hypothesis that can move ``source``
        (the fitted ones of its side; for the tone sources also the calibration's error
        modes, which every fit profiles out) with their finite-difference steps."""
        fit = self.fit
        side = _SOURCE_SIDE[source]
        out = []
        for par in fit.parameters:
            if param_side(self.prob, par.name) == side:
                out.append((par.name, PARAM_STEP * float(par.scale)))
        if side == "tones" and source in ("powers", "phase"):
            modes = [k for k in getattr(getattr(self.prob, "tone", None), "mode_names", ())
                     if source == "powers" or k.startswith("cal_phase")]
            out += [(k, MODE_STEP) for k in modes]
        return out

    def covariance(self, keys: list) -> np.ndarray | None:
        """Covariance of the parameters ``keys`` from the recordings so far: the fit's
        (Gauss-Newton, calibration modes profiled out) for the fitted ones, the modes'
        posterior ``(J^T J + I)^-1`` on the recordings for the calibration modes (the
        two blocks taken as uncorrelated); None without a covariance."""
        fit = self.fit
        if fit.cov is None or not keys:
            return None
        n = len(keys)
        C = np.zeros((n, n))
        fitted = [i for i, k in enumerate(keys) if k in fit.free]
        if fitted:
            idx = [fit.free.index(keys[i]) for i in fitted]
            sub = np.asarray(fit.cov, float)[np.ix_(idx, idx)]
            if not np.all(np.isfinite(sub)):
                return None
            C[np.ix_(fitted, fitted)] = sub
        modes = [i for i, k in enumerate(keys) if k not in fit.free]
        if modes:
            M = self._modes_posterior()
            names = list(getattr(self.prob.tone, "mode_names", ()))
            j = [names.index(keys[i]) for i in modes]
            C[np.ix_(modes, modes)] = M[np.ix_(j, j)]
        return C

    def _modes_posterior(self) -> np.ndarray:
        if self._mode_cov is None:
            names = list(getattr(self.prob.tone, "mode_names", ()))

            def z(p):
                r = self.prob.residuals(p, with_prior=False)
                return np.where(np.isfinite(r), r, 0.0)

            z0 = z(self.p)
            J = np.empty((z0.size, len(names)))
            for i, k in enumerate(names):
                J[:, i] = (z({**self.p, k: self.p.get(k, 0.0) + MODE_STEP}) - z0) / MODE_STEP
            self._mode_cov = np.linalg.inv(J.T @ J + np.eye(len(names)))
        return self._mode_cov


def _powers(h: Hypothesis, p: dict):
    return h.tone.tone_powers_at(SPECTRA_GRID, p)


def _gates(h: Hypothesis, p: dict):
    return h.gate.predict(p)


def _drift(h: Hypothesis, p: dict):
    ra = h.prob.runs_after
    days = np.array([float(np.max(ra.days)) if ra is not None else 0.0])
    return run_drift(h.prob, p, days)[0]


def phase_run_amplitudes(prob) -> np.ndarray:
    """The amplitudes a further phase run records and the diagnosis fits: the model's
    run's (``A >= PHASE_MIN_A``), else :data:`RUN_AMPLITUDES` there."""
    pts = getattr(getattr(prob, "camp", None), "phase_points", None)
    return pts[0] if pts is not None else RUN_AMPLITUDES[RUN_AMPLITUDES >= PHASE_MIN_A]


def _phase(h: Hypothesis, p: dict):
    # the phase a run records, as the diagnosis fits the runs after the recordings
    return recorded_phase(h.tone, p, phase_run_amplitudes(h.prob))


def _spam(h: Hypothesis, p: dict):
    return spam_probabilities(h.gate.preparation(p), SPAM_STATES)


def pulse_amplitude(camp) -> float:
    """The step amplitude of a further pulse response: the campaign's own trace's (its
    first step), else the time scans' amplitude (the gate's) when they have one, else the
    largest amplitude of the spectra (where a memory of the drive power shows most)."""
    pulse = getattr(camp, "pulse_response", None)
    if pulse is not None:
        return float(pulse["A"].iloc[0])
    ts = getattr(camp, "time_scans", None)
    amps = () if ts is None else np.unique(np.asarray(ts["A"], dtype=float))
    return float(amps[0]) if len(amps) == 1 else float(np.max(camp.A_tones))


def _pulse(h: Hypothesis, p: dict):
    m = pulse_prediction(h.tone, p, pulse_amplitude(h.prob.camp), PULSE_TIMES_US)
    return m / m[-1] if m[-1] > 0 else m


def _ramsey(h: Hypothesis, p: dict):
    gm = h.gate
    t = scan_waits(gm.nominal["T2"])
    active = active_effects(gm.effects, p)
    return np.concatenate([ramsey_probabilities_of(gm, p, active, t, s == "echo")
                           for s in SEQUENCES])


def linearity_readings(prob) -> np.ndarray:
    """The plain photodiode readings at :data:`LINEARITY_DRIVES` (lab units): the model
    run's amplitude curve there (a stale table or a drift moves them a few percent, not
    what the attenuator's ratio says)."""
    return np.asarray(prob.camp.amplitude.power(LINEARITY_DRIVES), dtype=float)


def _linearity(h: Hypothesis, p: dict):
    # the hypothesis's own tone model (its P_max) and the effects' photodiode
    return predicted_attenuated(h, p, linearity_readings(h.prob),
                                transmission(LINEARITY_ATTENUATION_DB))


def _thermometry(h: Hypothesis, p: dict):
    waits = np.repeat(np.asarray(THERMOMETRY_WAITS_US, float), len(SIDEBANDS)) * 1e-6
    sidebands = np.tile(np.asarray(SIDEBANDS), len(THERMOMETRY_WAITS_US))
    return thermometry_probabilities(h.gate, p, waits, sidebands)


_SOURCES = {"powers": _powers, "gates": _gates, "drift": _drift, "phase": _phase,
            "spam": _spam, "pulse": _pulse, "ramsey": _ramsey, "linearity": _linearity,
            "thermometry": _thermometry}
