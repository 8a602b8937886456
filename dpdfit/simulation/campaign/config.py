"""Generating parameters of a simulated campaign and the effects the simulator can conceal.

:data:`SIMULATOR_EFFECTS` names the knobs of *this simulator* (what
``dpdfit simulate-campaign --effects`` accepts); it is not the diagnosis's
catalog of effect models (:mod:`dpdfit.analyses.diagnosis`), although most
names coincide.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from dpdfit.analyses.diagnosis.effects import get
from dpdfit.core.defaults import (AMPLITUDE_ORDER, ERROR_MODEL, ETA_LD, ETA_REF, NU_HZ,
                                  XI0_SPECTRA_HZ)
from dpdfit.errors import InputError
from dpdfit.simulation.aom_truth import A_CORR, PHI_1, HeterodyneNoise, PhotodiodeNoise

__all__ = ["SIMULATOR_EFFECTS", "DEFAULT_SEED", "parse_effects", "CampaignConfig", "rng_for"]

#: Seed of the bundled campaign (``datasets/synthetic_campaign``): ``ERROR_MODEL.seed``.
DEFAULT_SEED = ERROR_MODEL.seed

#: Effects that can be concealed in a simulated campaign: name -> (unit, meaning).
SIMULATOR_EFFECTS = {
    "aom_memory": ("ns", "single-pole memory of the modulator, time constant (Wiener model)"),
    "aom_memory_offset": ("MHz", "offset of the AOM response centre from the carrier "
                                 "(red/blue asymmetry of the memory)"),
    "stale_calibration": ("days", "the predistortion table comes from the calibration run "
                                  "this many days before the gate day"),
    "motional_heating": ("quanta/ms", "heating rate of the stretch mode"),
    "dephasing": ("1/s", "extra qubit dephasing rate added to 1/T2"),
    "spam_offset": ("probability", "extra state-preparation error per ion"),
    "gate_rate_miscalibration": ("dB", "systematic optical-power offset between the xi0 "
                                       "calibration and the gate"),
    "detector_nonlinearity": ("1/full scale", "quadratic photodiode response "
                                              "P_meas = P (1 + k P/P_full) in calibrations"),
    "higher_nbar": ("quanta", "extra initial mean phonon number"),
    "am_pm_omitted": ("rad", "AM-to-PM conversion in the beam path after the calibrated AOM "
                             "(phase at full drive, ~|y|^2), not seen by the phase calibration"),
    "higher_order_im": ("1", "fifth-order field distortion after the calibrated AOM: relative "
                             "field change at full drive (~|y|^4)"),
    "calibration_drift": ("fraction", "A_corr of the calibration behind the predistortion table "
                                      "relative to the gate day (the AOM drifted since)"),
}


def parse_effects(spec: str | None) -> dict:
    """``"aom_memory=50,spam_offset=0.002"`` -> ``{"aom_memory": 50.0, ...}``."""
    out: dict = {}
    if not spec:
        return out
    for item in spec.split(","):
        name, sep, val = item.partition("=")
        name = name.strip()
        if name not in SIMULATOR_EFFECTS:
            raise InputError(f"unknown effect '{name}'; known: {', '.join(SIMULATOR_EFFECTS)}")
        try:
            if not sep:
                raise ValueError
            out[name] = float(val)
        except ValueError:
            raise InputError(f"effect '{item.strip()}' must be NAME=STRENGTH "
                             f"(strength in {SIMULATOR_EFFECTS[name][0]})") from None
        if not np.isfinite(out[name]):
            raise InputError(f"effect '{name}': strength must be finite")
    return out


@dataclass(frozen=True)
class CampaignConfig:
    """All generating parameters of a campaign (written to ``truth.json``).

    Units: amplitudes normalised, frequencies Hz, times s unless the name says
    otherwise (``_days``, ``_hours``, ``_us``, ``_khz``).
    """

    seed: int = DEFAULT_SEED
    start: str = "2025-08-04T08:30:00+00:00"
    # AOM truth and drift (Supplement S2)
    A_corr_mean: float = A_CORR
    A_corr_sigma: float = 0.0091
    A_corr_tau_days: float = 3.0
    phi1_mean: float = PHI_1
    phi1_sigma: float = 0.0009
    phi1_tau_hours: float = 1.0
    eta_ref: float = ETA_REF
    memory_tau: float = 0.0
    memory_offset_hz: float = 0.0
    # calibration recordings
    n_amp_runs: int = 34
    amp_span_days: float = 110.0
    n_phase_runs: int = 6
    phase_span_hours: float = 3.0
    cal_points: int = 201
    photodiode: PhotodiodeNoise = field(default_factory=PhotodiodeNoise)
    heterodyne_phase: HeterodyneNoise = field(default_factory=HeterodyneNoise)
    detector_nonlinearity: float = 0.0
    # predistortion
    lut_points: int = ERROR_MODEL.table_points
    order: int = AMPLITUDE_ORDER
    stale_days: float = 0.0
    table_drift: float = 0.0
    # beam path after the calibrated AOM (concealed effects; 0 = none)
    post_pm_rad: float = 0.0
    post_k5: float = 0.0
    # heterodyne spectra (Supplement S4)
    fs: float = 1e9
    n_samples: int = 2 ** 21
    f_det: float = 20e6
    nu: float = NU_HZ
    xi0_spec: float = XI0_SPECTRA_HZ
    trace_amplitudes: tuple = tuple(np.round(np.linspace(0.05, 1.0, 39), 4))
    trace_noise_rms: float = 0.015
    power_jitter_db: float = ERROR_MODEL.power_jitter_db
    bundled_traces: tuple = ((0.5, 0), (0.5, 1))
    spectra_harmonics: tuple = (-1, 0, 1, 2, 3, 4)
    #: "traces": synthesise every heterodyne trace and extract its tones (S4);
    #: "direct": exact tone amplitudes of the field plus the complex noise that
    #: the flat-top extraction of such a trace would add (fast; harness campaigns)
    spectra_mode: str = "traces"
    # gate experiments (Supplement S7, main text)
    gate_amplitudes: tuple = (0.4, 0.5, 0.6, 0.7, 0.8)
    eta_ld: float = ETA_LD
    # the lab's error model (dpdfit.core.defaults.ERROR_MODEL) is the nominal truth
    nbar: float = ERROR_MODEL.nbar
    alpha_khz: float = 3.42
    xi0_rel_err: float = ERROR_MODEL.xi0_rel_err
    T2: float = ERROR_MODEL.T2_s
    extra_dephasing: float = 0.0
    ndot: float = ERROR_MODEL.heating_quanta_per_s
    p_prep: float = ERROR_MODEL.p_prep
    p_det: float = ERROR_MODEL.p_det
    gate_power_offset_db: float = 0.0
    scan_shots: tuple = ((625, 625), (625, 625), (500, 625), (625, 400))
    time_scan_A: float = 0.5
    time_scan_points: int = 25
    time_scan_max: float = 1.5
    harmonics_gate: tuple = tuple(range(-2, 6))
    effects: dict = field(default_factory=dict)
    #: calibration runs recorded after the spectra and gates (the last ones)
    runs_after_recordings: int = 0
    #: hours after the table's run at which the spectra and the gates are recorded
    recording_hours: tuple = (4.0, 6.0)
    #: effects of the diagnosis's catalog injected with the given values, by their own
    #: hooks: ``((name, ((param, value), ...)), ...)`` (:meth:`inject`)
    injected: tuple = ()
    #: recordings added after the campaign (one further measurement each, e.g. of the
    #: closed loop, :mod:`dpdfit.simulation.closed_loop`): ``("amplitude_run",)``,
    #: ``("phase_run",)``, ``("scan", A, dpd, shots_pop, shots_par)`` or
    #: ``("time_scan", A, dpd, shots, points)`` (shots per point; points with ``t = 0``,
    #: as ``time_scan_points``; parity shots per phase).  Item ``j`` draws only from its own
    #: stream (purpose 8, ``j``), so every other recording is drawn as without it.
    further: tuple = ()

    def inject(self, effects: dict) -> "CampaignConfig":
        """Config with catalog effects injected: ``{name: {param: value}}`` (values in
        the effect's own injection terms, :meth:`~dpdfit.analyses.diagnosis.effects.Effect.draw`)."""
        inj = tuple((name, tuple(sorted(get(name).injected(v).items())))
                    for name, v in effects.items())
        return dataclasses.replace(self, injected=self.injected + inj)

    def injections(self) -> list:
        """The injected effects and their values: ``[(Effect, {param: value})]``."""
        if not self.injected:
            return []
        return [(get(name), dict(items)) for name, items in self.injected]

    def with_effects(self, effects: dict) -> "CampaignConfig":
        """Config with the named effects applied (see :data:`SIMULATOR_EFFECTS`)."""
        kw = {}
        for name, s in effects.items():
            if name == "aom_memory":
                kw["memory_tau"] = s * 1e-9
            elif name == "aom_memory_offset":
                kw["memory_offset_hz"] = s * 1e6
            elif name == "stale_calibration":
                kw["stale_days"] = s
            elif name == "motional_heating":
                kw["ndot"] = s * 1e3
            elif name == "dephasing":
                kw["extra_dephasing"] = s
            elif name == "spam_offset":
                kw["p_prep"] = self.p_prep + s
            elif name == "gate_rate_miscalibration":
                kw["gate_power_offset_db"] = s
            elif name == "detector_nonlinearity":
                kw["detector_nonlinearity"] = s
            elif name == "higher_nbar":
                kw["nbar"] = self.nbar + s
            elif name == "am_pm_omitted":
                kw["post_pm_rad"] = s
            elif name == "higher_order_im":
                kw["post_k5"] = s
            elif name == "calibration_drift":
                kw["table_drift"] = s
        return dataclasses.replace(self, effects=dict(effects), **kw)


def rng_for(cfg: CampaignConfig, *key: int) -> np.random.Generator:
    """The random stream of one purpose: ``SeedSequence([cfg.seed, *key])``.

    Keys: 1 calibration drift, 2 amplitude run, 3 phase run, 4 trace, 5 gates,
    7 the drifted calibration behind the table (``calibration_drift``), 8 the
    further recordings (``further``, by index).
    """
    return np.random.default_rng(np.random.SeedSequence([cfg.seed, *key]))
