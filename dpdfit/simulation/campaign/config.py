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
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.core.defaults import (AMPLITUDE_ORDER, ERROR_MODEL, ETA_LD, ETA_REF, INTEGER_MAX,
                                  MAX_CAMPAIGN_DAYS, MAX_SCHEDULE_ROWS, MAX_SHOTS,
                                  MAX_SIMULATED_POINTS, MAX_SIMULATED_ROWS, MAX_SIMULATED_RUNS,
                                  MAX_SIMULATED_SETTINGS, MAX_TABLE_POINTS, MAX_TRACE_SAMPLES,
                                  NU_HZ, XI0_SPECTRA_HZ)
from dpdfit.errors import InputError
from dpdfit.fits.tones.extract import check_trace_layout
from dpdfit.models.waveforms import MAX_PRODUCT_ORDER, cardioid
from dpdfit.simulation import injections
from dpdfit.simulation.aom_truth import A_CORR, PHI_1, HeterodyneNoise, PhotodiodeNoise

from .truth_values import (BadValue, Effects, Fixed, Injected, Integer, ListOf, Modulus, Number,
                           Record, Tagged, Text, Timestamp)

__all__ = ["SIMULATOR_EFFECTS", "DEFAULT_SEED", "RETIRED_TRUTH_KEYS", "parse_effects",
           "CampaignConfig", "TRUTH_CONTRACT", "TRUTH_RELATIONS", "rng_for"]

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
    #: shots per prepared state of the campaign's SPAM characterisation (``spam.csv``:
    #: ``|00>`` and ``|11>`` prepared, detected with no gate); 0: none recorded
    spam_shots: int = 0
    #: traces of the campaign's AOM pulse response (``pulse_response.csv``: a step
    #: ``0 -> time_scan_A`` traced by a fast photodiode); 0: none recorded
    pulse_traces: int = 0
    #: shots per point of the campaign's Ramsey and spin-echo scan (``ramsey.csv``: both
    #: sequences at every wait of ``ramsey_runs.ramsey_waits``); 0: none recorded
    ramsey_shots: int = 0
    #: drives of the campaign's detector linearity characterisation
    #: (``detector_linearity.csv``: the photodiode read with and without a calibrated
    #: attenuator at each); 0: none recorded
    detector_linearity_points: int = 0
    #: shots per wait and sideband of the campaign's sideband thermometry
    #: (``thermometry.csv``, :mod:`~dpdfit.simulation.campaign.thermometry_runs`); 0: none
    thermometry_shots: int = 0
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
    #: ``("phase_run",)``, ``("scan", A, dpd, shots_pop, shots_par)``,
    #: ``("time_scan", A, dpd, shots, points)`` (shots per point; points with ``t = 0``,
    #: as ``time_scan_points``; parity shots per phase) or ``("spam", shots)`` (a SPAM
    #: characterisation, shots per prepared state), ``("pulse_response", A)`` (an AOM
    #: pulse response, one trace of a step to ``A``), ``("ramsey", shots)`` (a Ramsey
    #: and spin-echo scan, shots per point), ``("detector_linearity", points)`` (a
    #: detector linearity characterisation at ``points`` drives) or ``("thermometry",
    #: shots)`` (a sideband thermometry, shots per wait and sideband).  Item ``j`` draws
    #: only from its own stream (purpose 8, ``j``), so every other recording is drawn as
    #: without it.
    further: tuple = ()

    @classmethod
    def from_truth(cls, truth: dict, file: str = "truth.json") -> "CampaignConfig":
        """The config a campaign's ``truth.json`` records (its ``config``, or that dict itself).

        The inverse of what the simulator writes: nested noise models, tuples (nested
        ones too: ``injected``, ``further``, ``scan_shots``), ``effects`` as recorded (their
        injection is ``injected``: nothing is injected twice).  truth.json keeps 10
        significant digits and of a complex parameter (the heterodyne ``leak``) only its
        modulus, so the config is the recorded one to that precision (a leak of the
        default modulus is the default leak; another keeps the default's phase):
        written again, it gives the same ``config`` of truth.json.

        Every value is checked against :data:`TRUTH_CONTRACT` (its kind and range) and the
        values together against :data:`TRUTH_RELATIONS`, before anything is simulated; a
        key the simulator does not know, or a retired one that is not 0, is refused too.
        Each refusal is one InputError naming ``file`` and the key (``scan_shots[0][1]``).
        """
        d = truth.get("config", truth) if isinstance(truth, dict) else None
        if not isinstance(d, dict):
            raise InputError("its config is not a JSON object", file=file)
        d = dict(d)
        for k in RETIRED_TRUTH_KEYS:
            v = d.pop(k, 0.0)
            if isinstance(v, bool) or v not in (0, 0.0):
                raise InputError(f"config key '{k}' is not 0: this simulator injects effects "
                                 "only through 'injected'", file=file)
        unknown = sorted(set(d) - set(TRUTH_CONTRACT), key=str)
        if unknown:
            raise InputError(f"unknown config key {_quoted(unknown[0])}", file=file)
        try:
            kw = {k: TRUTH_CONTRACT[k].read(v, k) for k, v in d.items()}
            values = {f.name: kw.get(f.name, getattr(_DEFAULT, f.name))
                      for f in dataclasses.fields(cls)}
            for relation in TRUTH_RELATIONS:
                relation.check(values)
        except BadValue as exc:
            raise InputError(str(exc), file=file) from None
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


def _quoted(key) -> str:
    """A key of truth.json's config as a message quotes it (its first characters)."""
    text = str(key)
    return repr(text if len(text) <= 40 else text[:40] + "...")


_DEFAULT = CampaignConfig()


# What truth.json's config may hold: one kind per field (dpdfit.simulation.campaign.
# truth_values), with the physically possible range, and the resources the simulator
# takes bounded (dpdfit.core.defaults).  A field's default is always inside.
_FINITE = Number(-math.inf, math.inf, lo_open=True, hi_open=True)
_PROBABILITY = Number(0.0, 1.0)
#: an amplitude of a recording (normalised RF amplitude; 0 drives nothing)
_AMPLITUDE = Number(0.0, 1.0, lo_open=True)
_FLAG = Integer(0, 1)
#: a time scale of a drift, in its unit (days or hours): a second to a thousand years
_TIME_SCALE = Number(1e-5, 4e5)
#: a harmonic of the gate tones, within the mixing products the simulator's record keeps
_HARMONIC = Integer(-MAX_PRODUCT_ORDER, MAX_PRODUCT_ORDER)
#: the drive's own tones (Cardioid(1,2)): every list of harmonics holds them
_GATE_TONES = tuple(cardioid().n)
_SHOTS = Integer(1, MAX_SHOTS)
_A_CORR = Number(0.02, 2 / math.pi, hi_open=True, hi_text="2/pi")

#: the kind and range of each field of :class:`CampaignConfig` in truth.json's config
TRUTH_CONTRACT = {
    "seed": Integer(0, INTEGER_MAX),
    "start": Timestamp(1900, 2999),
    # the AOM: a compressing amplifier has A_corr in (0, 2/pi) (BraggAOM; its gain is
    # solved for A_corr above 0.0128); drifts are small, their time scales positive
    "A_corr_mean": _A_CORR,
    "A_corr_sigma": Number(0.0, 0.05),
    "A_corr_tau_days": _TIME_SCALE,
    "phi1_mean": Number(-math.pi, math.pi, lo_text="-pi", hi_text="pi"),
    "phi1_sigma": Number(0.0, 0.5),
    "phi1_tau_hours": _TIME_SCALE,
    "eta_ref": Number(0.0, 1.0, lo_open=True),
    "n_amp_runs": Integer(2, MAX_SIMULATED_RUNS),
    "amp_span_days": Number(0.0, MAX_CAMPAIGN_DAYS),
    "n_phase_runs": Integer(1, MAX_SIMULATED_RUNS),
    "phase_span_hours": Number(0.0, 24 * MAX_CAMPAIGN_DAYS),
    "cal_points": Integer(2, MAX_SIMULATED_POINTS),
    "photodiode": Record(PhotodiodeNoise, {
        "p_full": Number(1e-9, 1e9), "sigma_0": Number(1e-12, 1e9), "rel": Number(0.0, 1.0)}),
    "heterodyne_phase": Record(HeterodyneNoise, {
        "sigma_iq": Number(1e-12, 1.0), "leak": Modulus(HeterodyneNoise.leak, 0.0, 1.0),
        "s_lock": _PROBABILITY, "excess": Number(1.0, 1e6)}),
    "lut_points": Integer(2, MAX_TABLE_POINTS),
    "order": Integer(1, 20),
    "stale_days": Number(0.0, MAX_CAMPAIGN_DAYS),
    "table_drift": Number(-0.5, 0.5),
    # the heterodyne traces (relations below: the tones fit the record and the band)
    "fs": Number(1e6, 1e11),
    "n_samples": Integer(1, MAX_TRACE_SAMPLES),
    "f_det": Number(0.0, 1e10),
    "nu": Number(1e4, 1e9),
    "xi0_spec": Number(1e2, 1e7),
    "trace_amplitudes": ListOf(_AMPLITUDE, 1, MAX_SCHEDULE_ROWS),
    "trace_noise_rms": Number(1e-9, 1e3),
    "power_jitter_db": Number(0.0, 3.0),
    "bundled_traces": ListOf(Fixed(("A", "dpd"), (_AMPLITUDE, _FLAG)), 0,
                             MAX_SIMULATED_SETTINGS),
    "spectra_harmonics": ListOf(_HARMONIC, 1, 2 * MAX_PRODUCT_ORDER + 1, distinct=True,
                                holding=_GATE_TONES),
    "spectra_mode": Text(("traces", "direct")),
    # the gates (the engine's physical inputs: ErrorModel's ranges)
    "gate_amplitudes": ListOf(_AMPLITUDE, 1, MAX_SIMULATED_SETTINGS, distinct=True),
    "eta_ld": Number(0.0, 1.0, lo_open=True),
    "nbar": Number(0.0, 10.0),
    "alpha_khz": Number(1e-3, 1e3),
    "xi0_rel_err": Number(0.0, 0.1),
    "T2": Number(1e-6, math.inf, hi_open=True),       # the engine's rate 1/T2 is finite
    "ndot": Number(0.0, 1e4),
    "p_prep": _PROBABILITY,
    "p_det": _PROBABILITY,
    "scan_shots": ListOf(Fixed(("population shots", "parity shots"), (_SHOTS, _SHOTS)), 1,
                         MAX_SIMULATED_SETTINGS),
    "time_scan_A": _AMPLITUDE,
    "time_scan_points": Integer(2, MAX_SIMULATED_POINTS),
    "time_scan_max": Number(0.0, 10.0, lo_open=True),
    "spam_shots": Integer(0, MAX_SHOTS),
    "pulse_traces": Integer(0, MAX_SIMULATED_RUNS),
    "ramsey_shots": Integer(0, MAX_SHOTS),
    "detector_linearity_points": Integer(0, MAX_SIMULATED_POINTS),
    "thermometry_shots": Integer(0, MAX_SHOTS),
    "harmonics_gate": ListOf(_HARMONIC, 1, 2 * MAX_PRODUCT_ORDER + 1, distinct=True,
                             holding=_GATE_TONES),
    "effects": Effects(lambda name: _effect_param(name), _FINITE),
    "runs_after_recordings": Integer(0, MAX_SIMULATED_RUNS - 1),
    "recording_hours": Fixed(("spectra hours", "gates hours"),
                             (Number(0.0, 24 * MAX_CAMPAIGN_DAYS),) * 2),
    # an injected value is finite; a probability (the unit the effect declares) in [0, 1]
    "injected": Injected(MAX_SIMULATED_SETTINGS, _FINITE, {"probability": _PROBABILITY}),
    "further": ListOf(Tagged({
        "amplitude_run": Fixed((), ()), "phase_run": Fixed((), ()),
        "scan": Fixed(("A", "dpd", "population shots", "parity shots"),
                      (_AMPLITUDE, _FLAG, Integer(0, MAX_SHOTS), Integer(0, MAX_SHOTS))),
        "time_scan": Fixed(("A", "dpd", "shots", "points"),
                           (_AMPLITUDE, _FLAG, _SHOTS, Integer(2, MAX_SIMULATED_POINTS))),
        "spam": Fixed(("shots",), (_SHOTS,)),
        "pulse_response": Fixed(("A",), (_AMPLITUDE,)),
        "ramsey": Fixed(("shots",), (_SHOTS,)),
        "detector_linearity": Fixed(("points",), (Integer(2, MAX_SIMULATED_POINTS),)),
        "thermometry": Fixed(("shots",), (_SHOTS,))}),
        0, MAX_SCHEDULE_ROWS),
}


@dataclass(frozen=True)
class _Relation:
    """What the values of several fields must satisfy together: ``reason(values)`` is
    None when they do, else why not."""

    keys: tuple
    reason: Callable

    def check(self, values: dict) -> None:
        why = self.reason(values)
        if why:
            raise BadValue.together(self.keys, why)


def _calibration_rows(v: dict) -> str | None:
    runs = v["n_amp_runs"] + v["n_phase_runs"] + sum(
        1 for item in v["further"] if item[0] in ("amplitude_run", "phase_run"))
    if runs * v["cal_points"] > MAX_SIMULATED_ROWS:
        return (f"{runs} calibration runs of cal_points = {v['cal_points']} points are "
                f"{runs * v['cal_points']} rows, more than the {MAX_SIMULATED_ROWS:.0e} the "
                "simulator makes")
    return None


def _drift_range(v: dict) -> str | None:
    # a compressing amplifier's A_corr (BraggAOM) for the drifting runs, 6 standard
    # deviations out (a draw beyond: 1 in 10^9), and for the table's calibration, one run
    # moved by table_drift, 4 out (1 in 30000)
    lo, hi = _A_CORR.lo, _A_CORR.hi
    mean, sigma, table = v["A_corr_mean"], v["A_corr_sigma"], 1.0 + v["table_drift"]
    for what, low, high in (("A_corr_mean +- 6 A_corr_sigma", mean - 6 * sigma,
                             mean + 6 * sigma),
                            ("A_corr_mean (1 + table_drift) +- 4 A_corr_sigma",
                             mean * table - 4 * sigma, mean * table + 4 * sigma)):
        if low <= lo or high >= hi:
            return (f"{what} must stay in ({lo:g}, 2/pi), a compressing amplifier's "
                    f"A_corr, not {low:.4g} .. {high:.4g}")
    return None


def _tone_ratio(v: dict) -> str | None:
    # the gate engine's record puts every tone on an FFT bin (sample_grid: nu/xi0 a ratio
    # of integers, denominator <= 64) and the highest harmonic's red tone above 0 Hz
    ratio = v["nu"] / v["xi0_spec"]
    exact = Fraction(ratio).limit_denominator(64)
    if not MAX_PRODUCT_ORDER < ratio <= 1000 or abs(float(exact) - ratio) > 1e-9 * ratio:
        return (f"nu/xi0_spec must be a ratio of integers with denominator <= 64 in "
                f"({MAX_PRODUCT_ORDER}, 1000], not {ratio:.10g}")
    return None


def _record_length(v: dict) -> str | None:
    # one gate period of the drive (fs/xi0_spec samples) fits a trace; the traces are
    # read as a lab's would be (check_trace_layout: resolution, band, tones apart)
    period = v["fs"] / v["xi0_spec"]
    if period > v["n_samples"]:
        return (f"a trace of n_samples = {v['n_samples']} must hold a gate period of "
                f"fs/xi0_spec = {period:.6g} samples")
    if v["spectra_mode"] == "traces":
        try:
            check_trace_layout(v["n_samples"], v["fs"], v["f_det"], v["nu"], v["xi0_spec"],
                               v["spectra_harmonics"])
        except InputError as exc:
            return f"its traces could not be read: {exc}"
    return None


#: what the values of several fields must satisfy together (checked after each value)
TRUTH_RELATIONS = (
    _Relation(("runs_after_recordings", "n_amp_runs"),
              lambda v: None if v["runs_after_recordings"] < v["n_amp_runs"] else
              "the gate day's amplitude run is one of the n_amp_runs: runs_after_recordings "
              f"must be below n_amp_runs, not {v['runs_after_recordings']} of "
              f"{v['n_amp_runs']}"),
    _Relation(("n_amp_runs", "n_phase_runs", "cal_points", "further"), _calibration_rows),
    _Relation(("cal_points", "order"),
              lambda v: None if v["cal_points"] > v["order"] + 1 else
              f"a calibration run of cal_points = {v['cal_points']} points cannot fit an "
              f"amplitude polynomial of order {v['order']} (more than order + 1 points)"),
    _Relation(("time_scan_A", "gate_amplitudes"),
              lambda v: None if v["time_scan_A"] in v["gate_amplitudes"] else
              f"the time scans are at a gate setting: time_scan_A = {v['time_scan_A']:g} "
              "must be one of gate_amplitudes"),
    _Relation(("A_corr_mean", "A_corr_sigma", "table_drift"), _drift_range),
    _Relation(("nu", "xi0_spec"), _tone_ratio),
    _Relation(("fs", "xi0_spec", "n_samples", "f_det", "nu", "spectra_harmonics",
               "spectra_mode"), _record_length),
)


def rng_for(cfg: CampaignConfig, *key: int) -> np.random.Generator:
    """The random stream of one purpose: ``SeedSequence([cfg.seed, *key])``.

    Keys: 1 calibration drift, 2 amplitude run, 3 phase run, 4 trace, 5 gates,
    7 the drifted calibration behind the table (``table_drift``), 8 the
    further recordings (``further``, by index), 9 the SPAM characterisation
    (``spam_shots``), 13 the detector linearity characterisation
    (``detector_linearity_points``), 14 the sideband thermometry (``thermometry_shots``),
    15 the AOM pulse response (``pulse_traces``, by trace), 21 the Ramsey and spin-echo
    scan (``ramsey_shots``).
    """
    return np.random.default_rng(np.random.SeedSequence([cfg.seed, *key]))
