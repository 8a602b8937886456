"""Generating parameters of a simulated campaign and the effects it can conceal.

Effects are injected only through the diagnosis's registry
(:mod:`dpdfit.analyses.diagnosis.effects`): each effect's injection's ``inject_*``
hooks act in the simulator (:mod:`dpdfit.simulation.injections`), and ``dpdfit
simulate-campaign --effects NAME=S`` sets the one parameter its
:meth:`~dpdfit.simulation.injections.Injection.strength_of` names (``NAME.PARAM=V``
sets another of its parameters).  :data:`SIMULATOR_EFFECTS` is a read-only view of
that registry.  Two knobs of the simulator are not effects but
its own parameters: :attr:`CampaignConfig.stale_days` and
:attr:`CampaignConfig.table_drift`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.core.defaults import (AMPLITUDE_ORDER, ERROR_MODEL, ETA_LD, ETA_REF, NU_HZ,
                                  XI0_SPECTRA_HZ)
from dpdfit.errors import InputError
from dpdfit.simulation import injections
from dpdfit.simulation.aom_truth import A_CORR, PHI_1, HeterodyneNoise, PhotodiodeNoise

__all__ = ["SIMULATOR_EFFECTS", "DEFAULT_SEED", "RETIRED_TRUTH_KEYS", "parse_effects",
           "CampaignConfig", "rng_for"]

#: Seed of the bundled campaign (``datasets/synthetic_campaign``): ``ERROR_MODEL.seed``.
DEFAULT_SEED = ERROR_MODEL.seed

#: keys of truth.json's ``config`` whose parameters the simulator no longer has (effects
#: are injected through the registry only, ``injected``): written as 0, so that the
#: truth.json of a campaign keeps its keys (the bundled campaigns byte for byte)
RETIRED_TRUTH_KEYS = ("memory_tau", "memory_offset_hz", "detector_nonlinearity",
                      "post_pm_rad", "post_k5", "extra_dephasing", "gate_power_offset_db")


class _SimulatorEffects(Mapping):
    """The registered effects as ``name -> (unit, meaning)`` of their strength (read
    from the registry at each access: effects registered later are included)."""

    def __getitem__(self, name):
        _, unit, meaning = injections.get(name).strength_of()
        return unit, meaning

    def __iter__(self):
        return iter(list(EFFECTS))

    def __len__(self):
        return len(EFFECTS)

    def __repr__(self):
        return f"SIMULATOR_EFFECTS({dict(self)!r})"


#: Effects that can be concealed in a simulated campaign: name -> (unit, meaning) of the
#: strength ``--effects NAME=S`` sets; a read-only view of the effect registry.
SIMULATOR_EFFECTS = _SimulatorEffects()


def _effect_param(name: str) -> tuple:
    """``(effect, param)`` of an ``--effects`` key: ``NAME`` (its strength) or
    ``NAME.PARAM``."""
    eff, dot, par = name.partition(".")
    if eff not in EFFECTS:
        raise InputError(f"unknown effect '{eff}'; known: {', '.join(EFFECTS)}")
    e = injections.get(eff)
    if not dot:
        return eff, e.strength_of()[0]
    known = list(e.injection_params())    # the parameters its injection takes
    if par not in known:
        raise InputError(f"effect '{eff}' has no parameter '{par}'; known: {', '.join(known)}")
    return eff, par


def parse_effects(spec: str | None) -> dict:
    """``"aom_memory=50,aom_memory.f_off=2"`` -> ``{"aom_memory": 50.0, "aom_memory.f_off":
    2.0}``: a registered effect's strength (:data:`SIMULATOR_EFFECTS`) or one of its
    parameters (``NAME.PARAM``, in that parameter's unit)."""
    out: dict = {}
    if not spec:
        return out
    for item in spec.split(","):
        name, sep, val = item.partition("=")
        name = name.strip()
        eff, par = _effect_param(name)
        try:
            if not sep:
                raise ValueError
            out[name] = float(val)
        except ValueError:
            unit = (SIMULATOR_EFFECTS[eff][0] if "." not in name else
                    next((p.unit for p in EFFECTS[eff].parameters() if p.name == par), "its unit"))
            raise InputError(f"effect '{item.strip()}' must be NAME=STRENGTH "
                             f"(strength in {unit})") from None
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
    # calibration recordings
    n_amp_runs: int = 34
    amp_span_days: float = 110.0
    n_phase_runs: int = 6
    phase_span_hours: float = 3.0
    cal_points: int = 201
    photodiode: PhotodiodeNoise = field(default_factory=PhotodiodeNoise)
    heterodyne_phase: HeterodyneNoise = field(default_factory=HeterodyneNoise)
    # predistortion
    lut_points: int = ERROR_MODEL.table_points
    order: int = AMPLITUDE_ORDER
    #: simulator knobs, not effects: the table comes from the calibration run this many
    #: days before the gate day, and from a calibration of the AOM whose A_corr was this
    #: fraction off the table run's (an unrecorded run, stream 7)
    stale_days: float = 0.0
    table_drift: float = 0.0
    # heterodyne spectra (Supplement S4)
    fs: float = 1e9
    n_samples: int = 2 ** 21
    f_det: float = 20e6
    nu: float = NU_HZ
    xi0_spec: float = XI0_SPECTRA_HZ
    #: amplitudes of the heterodyne traces (both flags each); an amplitude listed again
    #: is recorded again (repeated rows of spectra.csv, each trace with the stream of its
    #: index, so appending one leaves every earlier trace as it was)
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
    ndot: float = ERROR_MODEL.heating_quanta_per_s
    p_prep: float = ERROR_MODEL.p_prep
    p_det: float = ERROR_MODEL.p_det
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

    @classmethod
    def from_truth(cls, truth: dict) -> "CampaignConfig":
        """The config a campaign's ``truth.json`` records (its ``config``, or that dict itself).

        The inverse of what the simulator writes: nested noise models, tuples (nested
        ones too: ``injected``, ``further``, ``scan_shots``), ``effects`` as recorded (their
        injection is ``injected``: nothing is injected twice).  truth.json keeps 10
        significant digits and of a complex parameter (the heterodyne ``leak``) only its
        modulus, so the config is the recorded one to that precision (a leak of the
        default modulus is the default leak; another keeps the default's phase):
        written again, it gives the same ``config`` of truth.json.  A key the simulator
        does not know, or a retired one that is not 0, is refused (InputError).
        """
        d = dict(truth.get("config", truth)) if isinstance(truth, dict) else None
        if d is None:
            raise InputError("truth.json: its config is not a JSON object")
        for k in RETIRED_TRUTH_KEYS:
            if d.pop(k, 0.0) not in (0, 0.0):
                raise InputError(f"truth.json: config key '{k}' is not 0: this simulator "
                                 "injects effects only through 'injected'")
        fields = {f.name: f for f in dataclasses.fields(cls)}
        unknown = sorted(set(d) - set(fields))
        if unknown:
            raise InputError(f"truth.json: unknown config key '{unknown[0]}'")
        default = cls()
        kw = {k: _from_json(getattr(default, k), v, k) for k, v in d.items()}
        return cls(**kw)

    def inject(self, effects: dict) -> "CampaignConfig":
        """Config with catalog effects injected: ``{name: {param: value}}`` (values in
        the effect's own injection terms, :meth:`~dpdfit.simulation.injections.Injection.draw`)."""
        inj = tuple((name, tuple(sorted(injections.get(name).injected(v).items())))
                    for name, v in effects.items())
        return dataclasses.replace(self, injected=self.injected + inj)

    def injections(self) -> list:
        """The injected effects and their values: ``[(Injection, {param: value})]``."""
        if not self.injected:
            return []
        return [(injections.get(name), dict(items)) for name, items in self.injected]

    def with_effects(self, effects: dict) -> "CampaignConfig":
        """Config with the ``--effects`` of :func:`parse_effects` injected through the
        registry (:meth:`inject`): ``{NAME: strength, "NAME.PARAM": value}``."""
        values: dict = {}
        for name, s in effects.items():
            eff, par = _effect_param(name)
            values.setdefault(eff, {})[par] = float(s)
        cfg = self.inject(values) if values else self
        return dataclasses.replace(cfg, effects=dict(effects))


def _tuples(v):
    return tuple(_tuples(x) for x in v) if isinstance(v, list) else v


def _from_json(default, v, key: str):
    """A config value from its truth.json form, shaped as the field's ``default``."""
    if dataclasses.is_dataclass(default):
        if not isinstance(v, dict) or set(v) - {f.name for f in dataclasses.fields(default)}:
            raise InputError(f"truth.json: config key '{key}' is not a {type(default).__name__}")
        return dataclasses.replace(default, **{k: _from_json(getattr(default, k), x, f"{key}.{k}")
                                               for k, x in v.items()})
    if isinstance(default, complex):
        # truth.json keeps the modulus only (10 digits): the default's phase
        if float(f"{abs(default):.10g}") == v:
            return default
        return complex(v * np.exp(1j * np.angle(default)))
    if isinstance(default, tuple):
        if not isinstance(v, list):
            raise InputError(f"truth.json: config key '{key}' is not a list")
        return _tuples(v)
    if isinstance(default, dict) and not isinstance(v, dict):
        raise InputError(f"truth.json: config key '{key}' is not an object")
    return v


def rng_for(cfg: CampaignConfig, *key: int) -> np.random.Generator:
    """The random stream of one purpose: ``SeedSequence([cfg.seed, *key])``.

    Keys: 1 calibration drift, 2 amplitude run, 3 phase run, 4 trace, 5 gates,
    7 the drifted calibration behind the table (``table_drift``), 8 the
    further recordings (``further``, by index).
    """
    return np.random.default_rng(np.random.SeedSequence([cfg.seed, *key]))
