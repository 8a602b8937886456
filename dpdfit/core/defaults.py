"""The experiment's default constants, defined once (the paper's values).

Every default a function signature, a command-line option or a campaign folder
falls back to is taken from here, so that a lab changes it in one place.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from dpdfit.errors import InputError

__all__ = ["NU_HZ", "XI0_SPECTRA_HZ", "NBAR", "ETA_REF", "ETA_LD", "AMPLITUDE_ORDER",
           "PHASE_ORDER", "PHASE_MIN_A", "FORMULA", "FORMULAS", "DIAGNOSIS_PAIRS",
           "HARNESS_PER_EFFECT", "HARNESS_NULLS", "HARNESS_PAIRS", "HARNESS_TRIPLES",
           "HARNESS_PER_FORM", "HARNESS_SEED", "ErrorModel", "ERROR_MODEL", "LabTimes",
           "LAB_TIMES", "LINEARITY_POINTS", "LINEARITY_ATTENUATION_DB",
           "PHASE_RUN_NOISE_RAD", "MAX_DATASET_BYTES", "MAX_SCHEDULE_ROWS", "MAX_INPUT_BYTES",
           "MAX_INPUT_BYTES_VARIABLE", "MAX_JSON_BYTES", "MAX_JSON_DEPTH", "MAX_CSV_COLUMNS", "INTEGER_MAX",
           "FORMAT_MAX_CHARS", "FORMAT_MAX_WIDTH", "EXPR_MAX_CHARS", "EXPR_MAX_DEPTH",
           "EXPR_MAX_NODES", "EXPR_MAX_INTEGER", "EXPR_MAX_ROUND_DIGITS", "PYON_MAX_CHARS",
           "PYON_MAX_DEPTH", "MAX_FILES_PER_SOURCE", "MAX_TRACE_SAMPLES", "MAX_SIMULATED_RUNS",
           "MAX_SIMULATED_POINTS", "MAX_SIMULATED_ROWS", "MAX_TABLE_POINTS",
           "MAX_SIMULATED_SETTINGS", "MAX_SHOTS", "MAX_CAMPAIGN_DAYS"]

#: sideband detuning nu of the gate tones from the carrier, Hz (S4)
NU_HZ = 1.84e6
#: gate detuning xi0 of the recorded spectra, Hz (S4)
XI0_SPECTRA_HZ = 20e3
#: thermal mean phonon number of the gate mode assumed by the estimates
NBAR = 0.1
#: peak diffraction efficiency of the AOM (normalises eta_bar)
ETA_REF = 0.80
#: Lamb-Dicke parameter of the gate mode
ETA_LD = 0.026
#: polynomial order K of the amplitude transfer function
AMPLITUDE_ORDER = 8
#: polynomial order of the phase transfer function
PHASE_ORDER = 5
#: lowest drive amplitude used in the phase fit
PHASE_MIN_A = 0.1
#: the fidelity-estimate formula used by default ("exact" or "paper")
FORMULA = "exact"
#: the fidelity-estimate formulas there are (:func:`dpdfit.models.fidelity.estimate`)
FORMULAS = ("exact", "paper")
#: the diagnosis tries at most this many other effects as an addition at each step, the
#: best single effects first (``dpdfit diagnose --pairs``; 0: one effect only)
DIAGNOSIS_PAIRS = 8
#: the default size of the diagnosis harness's plan (``dpdfit harness``): campaigns per
#: concealed effect, null campaigns, pairs, triples, and (leave-one-form-out mode)
#: campaigns per form of each effect
HARNESS_PER_EFFECT = 20
HARNESS_NULLS = 20
HARNESS_PAIRS = 0
HARNESS_TRIPLES = 0
HARNESS_PER_FORM = 2
#: the default seed of the harness's injection plan
HARNESS_SEED = 7


# Section and table numbers below count the Supplement of the paper
# (../shared/000_25865f86b72c0b0d.txt) in order: S6.5 "Gate-rate uncertainty from power
# fluctuations", S7.2 "Parity fidelity", S10 "Error sources and limitations" with
# S10.1 "State preparation and measurement", S10.2 "Qubit dephasing", S10.3 "Motional
# heating" and its Table S2.


@dataclass(frozen=True)
class ErrorModel:
    """The lab's error model: one set of values for the gate engine, simulator and diagnosis.

    The first seven fields are the keys of a campaign's ``campaign.json``
    ``error_model`` object (:attr:`CAMPAIGN_KEYS`, :meth:`campaign_dict`); the
    other three are the lab's fixed recording choices that a campaign names
    elsewhere (``parity_phases``, ``predistortion_table.points``, the seed in
    ``generator``).  :meth:`from_dict` overlays a campaign's values on the
    defaults.  The error budget (:mod:`dpdfit.analyses.budget`) does not use
    this: it takes the paper's Table S2 inputs, which are bounds where these are
    point values (see the comment on its ``DEFAULT_CONFIG``).
    """

    #: thermal mean phonon number of the gate mode before the gate: :data:`NBAR`
    #: (main text "Experimental setup", sideband thermometry; S5 uses it in the estimate)
    nbar: float = NBAR
    #: qubit coherence time T2 [s]: Ramsey, 50 +/- 5 ms (S10.2, Table S2)
    T2_s: float = 50e-3
    #: motional heating rate of the stretch mode [quanta/s]: the paper gives only a
    #: bound, < 0.01 quanta/ms = 10 /s (main text "Experimental setup", S10.3,
    #: Table S2); 5 /s (half the bound, the mean of the budget's uniform prior on it)
    #: is this project's synthetic-lab choice
    heating_quanta_per_s: float = 5.0
    #: state-preparation error per ion: 1 - 0.997, the fitted Rabi-flop amplitude
    #: 0.997 +/- 0.003 (S10.1, Table S2 "<~ 0.6 %" for two ions)
    p_prep: float = 0.003
    #: bright/dark detection error per ion: the paper bounds it, < 1e-4 (S10.1;
    #: Table S2 "< 0.02 %" for two ions); 5e-5 (half the bound) is this project's
    #: synthetic-lab choice
    p_det: float = 5e-5
    #: laser-power fluctuation, 1 sigma [dB]: sigma_dB ~ 0.2 dB (S6.5)
    power_jitter_db: float = 0.2
    #: relative 1-sigma error of each setting's calibrated gate rate xi0: not given
    #: in the paper (xi0 is "precalibrated for each setting", main text); 1 % is
    #: this project's synthetic-lab choice
    xi0_rel_err: float = 0.01
    #: analysis phases of a parity-fringe scan, uniformly spaced on [0, 2 pi):
    #: 16, with 625 shots per phase (S7.2)
    parity_phases: int = 16
    #: points of the predistortion lookup table: not given in the paper; 4096 is
    #: this project's synthetic-lab choice
    table_points: int = 4096
    #: random seed of the bundled synthetic campaign (``datasets/synthetic_campaign``):
    #: this project's choice
    seed: int = 20260329

    #: the fields a campaign's ``campaign.json`` ``error_model`` object holds
    CAMPAIGN_KEYS: ClassVar[tuple[str, ...]] = (
        "nbar", "T2_s", "heating_quanta_per_s", "p_prep", "p_det", "power_jitter_db",
        "xi0_rel_err")
    _INTEGERS: ClassVar[tuple[str, ...]] = ("parity_phases", "table_points", "seed")
    _PROBABILITIES: ClassVar[tuple[str, ...]] = ("p_prep", "p_det")

    def __post_init__(self):
        for f in dataclasses.fields(self):
            object.__setattr__(self, f.name, _checked(f.name, getattr(self, f.name)))

    def to_dict(self) -> dict:
        """Every field, by name (plain ``float``/``int`` values)."""
        return dataclasses.asdict(self)

    def campaign_dict(self) -> dict:
        """The ``campaign.json`` ``error_model`` object: the :attr:`CAMPAIGN_KEYS` fields."""
        return {k: getattr(self, k) for k in self.CAMPAIGN_KEYS}

    @classmethod
    def from_dict(cls, values: dict, base: ErrorModel | None = None) -> ErrorModel:
        """``base`` (default :data:`ERROR_MODEL`) with the error-model keys ``values``
        names replaced.

        ``values`` is a campaign's ``error_model`` object: only the
        :attr:`CAMPAIGN_KEYS` (:meth:`campaign_dict`'s output).  Any other key (the
        campaign's ``parity_phases``, the simulator's ``table_points`` and ``seed``
        included) or a bad value is an :class:`InputError` naming it, with the
        nearest error-model key when there is one.  ``ErrorModel(**d)`` takes
        :meth:`to_dict`'s output.
        """
        if not isinstance(values, dict):
            raise InputError(f"error_model must be an object/dict, got {type(values).__name__}")
        for key in values:
            if key not in cls.CAMPAIGN_KEYS:
                near = difflib.get_close_matches(str(key), cls.CAMPAIGN_KEYS, n=1)
                hint = f" (did you mean '{near[0]}'?)" if near else ""
                raise InputError(f"unknown error_model key '{key}'{hint}; the error-model "
                                 f"keys are {', '.join(cls.CAMPAIGN_KEYS)}")
        return dataclasses.replace(ERROR_MODEL if base is None else base, **values)

    def analysis_phases(self) -> np.ndarray:
        """The parity scans' analysis phases [rad]: ``2 pi k / parity_phases``."""
        return np.arange(self.parity_phases) * 2 * np.pi / self.parity_phases


def _checked(key: str, value):
    """``value`` of ErrorModel field ``key`` as float/int, or InputError naming the key."""
    if key in ErrorModel._INTEGERS:
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise InputError(f"error_model key '{key}' must be an integer, got {value!r}")
        lowest = 0 if key == "seed" else 1
        if value < lowest:
            raise InputError(f"error_model key '{key}' must be >= {lowest}, got {value}")
        return int(value)
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputError(f"error_model key '{key}' must be a number, got {value!r}")
    try:
        value = float(value)
    except OverflowError:             # an integer beyond the float range (JSON allows it)
        raise InputError(f"error_model key '{key}' must be a finite number, got an integer "
                         f"of {len(str(abs(int(value))))} digits") from None
    if math.isnan(value) or value < 0 or (key == "T2_s" and value == 0):
        raise InputError(f"error_model key '{key}' must be "
                         f"{'> 0' if key == 'T2_s' else '>= 0'}, got {value}")
    if not math.isfinite(value) and key != "T2_s":
        raise InputError(f"error_model key '{key}' must be finite, got {value}")
    if key in ErrorModel._PROBABILITIES and value > 1:
        raise InputError(f"error_model key '{key}' must be a probability <= 1, got {value}")
    return value


#: the lab's error model: the default of the gate engine, the simulator and the diagnosis
ERROR_MODEL = ErrorModel()


@dataclass(frozen=True)
class LabTimes:
    """Lab time of each recording a diagnosis may propose next (seconds).

    Used by :func:`dpdfit.analyses.diagnosis.proposal.next_measurement.propose_next_measurement`
    to rank the menu by expected separation per lab hour; a lab passes its own
    ``LabTimes(...)`` to change them.  The paper states shot counts but no
    durations, so the values are typical trapped-ion lab figures, each argued below.
    """

    #: one amplitude calibration run: 101 amplitudes at ~3 s each (set the RF, let the
    #: photodiode settle, average), 5 min -- the duration of the campaigns' recorded runs
    amplitude_run_s: float = 300.0
    #: one phase calibration run: 101 amplitudes at ~4 s each (the phase is averaged over
    #: repetitions, Supplement "AOM phase response"), ~7 min as the campaigns' phase runs
    phase_run_s: float = 400.0
    #: one heterodyne trace (one amplitude, one DPD flag): upload the waveform, capture
    #: and store the beat note, about a minute with the re-arming of the AWG
    spectrum_trace_s: float = 60.0
    #: one experimental shot: Doppler and sideband cooling (several ms) dominate the
    #: 150-310 us gate and ~1 ms detection, so ~10 ms per shot (100 shots/s)
    shot_s: float = 0.01
    #: one shot of the SPAM characterisation (a basis state prepared, detected, no gate):
    #: Doppler cooling and optical pumping (~1 ms) and the ~1 ms detection, no sideband
    #: cooling and no gate, so ~2 ms per shot: 1000 shots of each of ``|00>`` and ``|11>`` in
    #: about 4 s, a few minutes with the repeats a decision needs
    spam_shot_s: float = 0.002
    #: one AOM pulse response (a step 0 -> A traced by a fast photodiode on a scope): the
    #: scope averages a few thousand steps at a repetition of ~1 kHz (a few seconds), and
    #: setting up the RF switch, the trigger and the photodiode in the beam takes most of
    #: a minute, so ~60 s per averaged trace
    pulse_trace_s: float = 60.0
    #: one shot of the Ramsey and spin-echo characterisation, the wait excluded (added per
    #: shot from the scan's waits): Doppler cooling and optical pumping (~1 ms), two or
    #: three carrier pulses (~10 us) and the ~1 ms detection, no sideband cooling, so
    #: ~2 ms per shot as for SPAM
    ramsey_shot_s: float = 0.002
    #: overhead per point of a Ramsey scan: the control system compiles and uploads the
    #: sequence of each wait and reads its counts back (ndscan/ARTIQ: ~0.5 s a point);
    #: 20 waits x 2 sequences x 200 shots is then about 2 minutes with the waits of a
    #: scan to 1.5 T2 (T2 = 50 ms)
    ramsey_point_s: float = 0.5
    #: one reading of the detector linearity characterisation (one drive, with or without
    #: the attenuator): set the RF, let the photodiode settle and average, ~3 s as a point
    #: of an amplitude calibration run, rounded up to 5 s for a longer average of the
    #: weaker attenuated reading; 10 drives read twice are ~2 min
    linearity_reading_s: float = 5.0
    #: putting the calibrated attenuator into the beam and taking it out again (a flip
    #: mount or a fibre attenuator: once for all drives, the beam's pointing on the
    #: photodiode checked), about a minute; so 10 drives take ~3 min in all
    attenuator_swap_s: float = 60.0
    #: one shot of the sideband thermometry, its wait not counted: Doppler cooling and
    #: sideband cooling of the gate mode (~1 ms), the ~0.1 ms sideband probe and the ~1 ms
    #: detection, no gate, so ~2 ms per shot; each shot also waits its ``wait_us`` (added
    #: by the menu): 8 waits up to 10 ms x 2 sidebands x 200 shots in about 16 s
    thermometry_shot_s: float = 0.002
    #: the longest recording the diagnosis proposes (repeats included): a working day
    max_seconds: float = 8 * 3600.0


#: the lab times of :class:`LabTimes` (the menu of next measurements)
LAB_TIMES = LabTimes()
#: drives of a detector linearity characterisation the menu proposes (the photodiode
#: read with and without the attenuator at each): 10 span the calibration's powers
#: from ~5 % of full scale to full scale, a few minutes of lab time (:class:`LabTimes`)
LINEARITY_POINTS = 10
#: the calibrated attenuator of a proposed detector linearity characterisation (dB): an
#: ND filter of optical density 1, its attenuated reading still ~100x the calibration
#: photodiode's noise floor at full drive
LINEARITY_ATTENUATION_DB = 10.0
#: noise (1 sigma, rad) of one point of a phase calibration run when the campaign has no
#: phase runs to learn it from: the paper's run-to-run sd of phi(1), 0.0009 rad over six
#: runs (Supplement, phase stability), rounded up
PHASE_RUN_NOISE_RAD = 1e-3
#: the largest HDF5 dataset the import reads from a results file, bytes (declared shape
#: times element size, checked before anything is read; a mapping raises it with
#: ``[import] max_dataset_bytes``): 256 MiB.  The largest record a mapping reads whole,
#: per-shot outcomes of 10^4 points x 10^3 shots in float64, is 80 MB; the import's copies
#: of one dataset that size (conversion to float, the table's column) stay near 1 GB,
#: which a lab PC has.  A damaged or hostile file can declare far more than it holds (a
#: chunked dataset never written reads as its fill value): it is refused, not allocated.
MAX_DATASET_BYTES = 256 * 2**20


# What an import mapping and a results file's expid may ask of the importer
# (dpdfit.recordings: mapping, value_formats, expressions, pyon).  Each bound is far
# beyond what a lab writes; a crafted file is refused in one line instead of taking
# the machine's memory or time.
#: largest integer (in magnitude) a mapping or a run's expid may hold: int64, the range
#: TOML promises, ARTIQ stores and the campaign tables hold
INTEGER_MAX = 2**63 - 1
#: longest ``format`` of a mapping column (``"R{:03d}"`` is 7 characters)
FORMAT_MAX_CHARS = 100
#: widest field and most digits after the point a ``format`` may ask for: str.format
#: pads to any width, so ``"{:300000000}"`` would build a 300 MB text per value
FORMAT_MAX_WIDTH = 100
#: longest ``expr`` of a mapping column (the guide's longest is 56 characters)
EXPR_MAX_CHARS = 1000
#: deepest nesting of an ``expr`` (calls, brackets, operators): the checker and the
#: evaluator recurse once per level
EXPR_MAX_DEPTH = 32
#: most parts (syntax-tree nodes) of an ``expr``; the sum of three datasets has 12
EXPR_MAX_NODES = 250
#: largest integer an ``expr`` may write: expressions compute in float64, which holds
#: every integer up to 2**53 exactly and no larger one reliably
EXPR_MAX_INTEGER = 2**53
#: most decimal places ``round(x, digits)`` may keep or drop: a value in SI units down to
#: 1e-13 (ps) still keeps float64's 17 significant digits; numpy fails beyond 2**31
EXPR_MAX_ROUND_DIGITS = 30
#: longest PYON text (a run's expid: its arguments, a few kB in the real ARTIQ file
#: the tests read; ndscan's parameter overrides add some)
PYON_MAX_CHARS = 1_000_000
#: deepest nesting of PYON (an expid nests dictionaries a few levels deep); the decoder
#: recurses once per level
PYON_MAX_DEPTH = 100

#: the most results files one source of an import mapping reads (its globs together): a
#: year of a busy lab's runs is tens of thousands; a glob that matches more has most
#: likely met the wrong tree (``**`` under a file server's root), and is refused before
#: the walk goes on
MAX_FILES_PER_SOURCE = 100_000

#: the most rows a schedule file (:mod:`dpdfit.recordings.schedule`) may hold: a working
#: day of the shortest recording the diagnosis proposes (population scans of a few
#: hundred shots) is a few thousand rows, a lab's own plan of calibration runs a few
#: tens of thousands; a file far beyond that is not a schedule
MAX_SCHEDULE_ROWS = 1_000_000

# What dpdfit reads from a file it is given (dpdfit.recordings.input_files): a campaign
# folder, new recordings, a schedule, a mapping, an earlier diagnosis.  Such a file may
# come from another lab, or be damaged: it is read only if it is a regular file of at
# most this size, checked before a byte of it is read.
#: the largest input file dpdfit reads, bytes: 1 GiB.  The largest table of a real
#: campaign, its spectra of ten thousand traces or a million counted rows, is tens of MB.
#: The environment variable ``DPDFIT_MAX_INPUT_BYTES`` (:data:`MAX_INPUT_BYTES_VARIABLE`)
#: raises or lowers it for one run.
MAX_INPUT_BYTES = 2**30
#: the environment variable that sets :data:`MAX_INPUT_BYTES` (bytes, an integer)
MAX_INPUT_BYTES_VARIABLE = "DPDFIT_MAX_INPUT_BYTES"
#: the largest JSON file dpdfit reads (``campaign.json``, an earlier diagnosis's JSON,
#: ``truth.json``): 64 MiB; a diagnosis's JSON is a few hundred kB
MAX_JSON_BYTES = 64 * 2**20
#: the most levels of lists and objects in a JSON file dpdfit reads: a diagnosis's JSON
#: has seven, ``truth.json`` and ``campaign.json`` fewer; the code that walks a value read
#: (to write it again, to compare it) goes one call deeper per level, and Python's stack
#: ends near a thousand
MAX_JSON_DEPTH = 64
#: the most columns of a CSV table (a campaign's widest table has about twenty)
MAX_CSV_COLUMNS = 1000

# What a simulated campaign's config may hold (its truth.json, read back when the simulator
# stands in for the lab: dpdfit.simulation.campaign.config.TRUTH_CONTRACT).  The simulator
# allocates and loops by these numbers, so each is bounded far beyond what a campaign holds,
# and a crafted truth.json is refused before anything is simulated.
#: samples of one simulated heterodyne trace: 2^24, 17 ms at 1 GS/s (the bundled traces
#: have 2^21); the simulator holds a few complex copies of a trace: one trace of 2^24
#: samples raised the peak memory by 1.0 GiB (0.13 GiB at 2^21)
MAX_TRACE_SAMPLES = 2**24
#: calibration runs of one kind in a simulated campaign (the bundled campaign has 34
#: amplitude runs and 6 phase runs, benchmarks/scale.py's 64x campaign 2176 and 384)
MAX_SIMULATED_RUNS = 100_000
#: points of one simulated calibration run or time scan (the bundled runs have 201)
MAX_SIMULATED_POINTS = 10_001
#: rows of a simulated campaign's calibration tables together (its runs times their
#: points: 8040 in the bundled campaign, 0.5 million in the 64x one), each a few hundred
#: bytes on the way to its CSV text
MAX_SIMULATED_ROWS = 10**7
#: points of a simulated predistortion table (:attr:`ErrorModel.table_points`: 4096)
MAX_TABLE_POINTS = 2**20
#: gate settings, scans per setting and bundled traces of a simulated campaign (a campaign
#: has a few of each; each scan of each setting is one run of the gate engine)
MAX_SIMULATED_SETTINGS = 1000
#: shots of one point of a simulated scan: 10^9, months of a lab at ~100 shots/s
MAX_SHOTS = 10**9
#: days a simulated campaign spans (its calibration runs, a stale table): ten years
MAX_CAMPAIGN_DAYS = 3650.0
