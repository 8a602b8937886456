"""The campaign folder: one reader, one set of rules, for every analysis.

``dpdfit analyze`` and ``dpdfit diagnose`` read a campaign folder (layout in
``docs/getting-started.md``, "The campaign folder") through :class:`CampaignFolder`.  Each
file is read and validated once, on first use, so that a malformed file stops
only the analyses that need it (``analyze``) while a missing *optional* file
or column only changes what is analysed; :meth:`CampaignFolder.left_out`
says what was left out and why.

Required and optional (everything else in the layout is optional):

* ``campaign.json`` -- required (a folder without it is not a campaign).
  Optional ``spectra_recorded`` and ``gates_recorded``: when the spectra and the
  gates were recorded (ISO 8601; no time zone = the calibration files'
  convention), :attr:`CampaignFolder.recording_times`.
  Keys default to the paper's values when absent (``nu_hz`` 1.84 MHz,
  ``xi0_spectra_hz`` 20 kHz, ``nbar_assumed`` 0.1, ``eta_ref`` 0.8, ``order``
  8, the latest amplitude run for the table, the latest phase run for the
  model); :attr:`CampaignFolder.defaults_used` lists which.  ``error_model``
  is optional: without it the diagnosis uses the paper's values with priors
  wide enough for real labs (:mod:`dpdfit.analyses.diagnosis.observables.campaign`).
* ``calibration_amplitude.csv`` -- required by every model-based analysis.
* ``calibration_phase.csv`` -- optional; without it the model has no AM-to-PM.
* ``spectra.csv`` -- ``A, dpd, sideband, n, P_dB``; optional columns
  ``valid`` (default 1), ``snr_db`` (without it the diagnosis estimates the
  noise floor from the recordings) and ``repeat`` (a tone recorded again is a
  further row; without the column its k-th row belongs to the k-th repeat):
  :mod:`dpdfit.recordings.spectra`.
* ``populations.csv`` -- ``A, dpd, scan, shots`` and ``n_even`` or
  ``n00, n01_10, n11`` (:func:`dpdfit.recordings.counts.read_populations`); without
  ``n00``/``n11`` the imbalance ``P00 - P11`` is not available.
* ``parity.csv`` -- :func:`dpdfit.recordings.counts.read_parity`.
* ``gate_rates.csv`` -- ``A, dpd, xi0_khz`` (+ ``xi0_err_khz``); a setting
  calibrated again is pooled (:func:`~dpdfit.recordings.gate_rates.read_gate_rates`).
* ``time_scans.csv`` -- ``A, dpd, t_us, n00, n11, shots`` (+ ``n01_10``: then
  ``n00 + n01_10 + n11 = shots`` is checked, else ``n00 + n11 <= shots``); a point
  recorded again has its counts summed (:func:`~dpdfit.recordings.counts.read_time_scans`).
* ``traces.csv`` + ``traces/`` -- ``file, A, dpd, fs, fdet, nu, xi0`` (+ ``repeat``:
  the repeat of ``spectra.csv`` the trace is).
* ``spam.csv`` -- the SPAM characterisation: ``prepared, n00, n01_10, n11, shots``
  (+ ``run``, ``timestamp``), :func:`~dpdfit.recordings.spam.read_spam`.  A
  characterisation table
  (:data:`~dpdfit.recordings.campaign_folder.CHARACTERISATION_FILES`): its absence
  leaves nothing of the other recordings' analysis out, so
  :meth:`CampaignFolder.left_out` does not list it.
* ``pulse_response.csv`` -- the AOM pulse response: ``t_us, power`` (+ ``A``,
  ``power_err``, ``run``, ``timestamp``),
  :func:`~dpdfit.recordings.pulse_response.read_pulse_response`; a characterisation
  table, as ``spam.csv``.
* ``ramsey.csv`` -- the Ramsey and spin-echo characterisation: ``sequence, wait_us,
  n00, n01_10, n11, shots`` (+ ``run``, ``timestamp``),
  :func:`~dpdfit.recordings.ramsey.read_ramsey`; its waits checked against the
  campaign's coherence time (:func:`~dpdfit.recordings.ramsey.check_ramsey_waits`).
  A characterisation table too.
* ``detector_linearity.csv`` -- the detector linearity characterisation: ``A, power,
  power_attenuated, attenuation_db`` (+ ``power_err``, ``run``, ``timestamp``),
  :func:`~dpdfit.recordings.detector_linearity.read_detector_linearity`; a
  characterisation table like ``spam.csv``.
* ``thermometry.csv`` -- sideband thermometry of the gate mode after a variable wait:
  ``wait_us, sideband, n_bright, shots`` (+ ``run``, ``timestamp``),
  :func:`~dpdfit.recordings.thermometry.read_thermometry`; a characterisation table.

Nothing is ever written into the folder.

The folder may come from elsewhere (a collaborator's, another lab's): every file is read
through :mod:`dpdfit.recordings.input_files`, inside the folder only.  When the folder is
opened, each file of the layout it has (and ``budget.toml``) must be a regular file, lying
inside the folder (a link may point elsewhere in it, never out), at most
:func:`~dpdfit.recordings.input_files.max_input_bytes` (``campaign.json``:
:data:`~dpdfit.core.defaults.MAX_JSON_BYTES`); so must each trace ``traces.csv`` lists,
whose array is at most that bound too (read from its header, before the samples are
loaded).  A file that is not so, or that is not a table a lab writes
(:mod:`dpdfit.recordings.csv_text`), is a :class:`~dpdfit.errors.RefusedFileError`
or is refused when the folder is opened: ``dpdfit analyze`` refuses the whole campaign.
"""

from __future__ import annotations

import datetime
import errno
import functools
import os
import stat
from pathlib import Path

import numpy as np
import pandas as pd

from dpdfit.core.defaults import (AMPLITUDE_ORDER, ERROR_MODEL, ETA_LD, ETA_REF, NBAR,
                                  NU_HZ, XI0_SPECTRA_HZ)
from dpdfit.core.jsonable import json_kind
from dpdfit.errors import ImplausibleValueError, InputError, RefusedFileError

from .columns import CAMPAIGN_TABLES, missing_column_lines
from .counts import read_parity, read_populations, read_time_scans
from .gate_rates import read_gate_rates
from .plausibility import check_gate_rates
from .calibration_runs import CalibrationData, calibration_data, calibration_runs_data, list_runs
from .detector_linearity import read_detector_linearity
from .input_files import check_inside, open_input, read_input_json
from .pulse_response import read_pulse_response
from .ramsey import check_ramsey_waits, read_ramsey
from .spam import read_spam
from .thermometry import read_thermometry
from .spectra import pool_spectra, read_spectra
from .tables import read_calibration_table, read_table
from .traces import check_trace_file

__all__ = ["CampaignFolder", "check_campaign_folder", "META_DEFAULTS", "FILES",
           "OTHER_FILES", "RECORDING_KEYS", "MAX_FUTURE_DAYS", "CHARACTERISATION_FILES"]

#: campaign.json keys stating when the recordings were taken (optional, ISO 8601)
RECORDING_KEYS = ("spectra_recorded", "gates_recorded")
#: a recording time this far beyond the last calibration run is refused as a typo
MAX_FUTURE_DAYS = 365.0

#: campaign.json constants and their defaults (the paper's values) when absent
META_DEFAULTS = {"nu_hz": NU_HZ, "xi0_spectra_hz": XI0_SPECTRA_HZ, "nbar_assumed": NBAR,
                 "eta_ref": ETA_REF, "eta_ld": ETA_LD, "order": AMPLITUDE_ORDER}
#: file -> (required by, what it holds)
FILES = {
    "campaign.json": "campaign constants",
    "calibration_amplitude.csv": "amplitude calibration runs",
    "calibration_phase.csv": "phase calibration runs (AM-to-PM)",
    "spectra.csv": "recorded heterodyne tone powers",
    "populations.csv": "population counts at the gate time",
    "parity.csv": "parity-fringe counts",
    "gate_rates.csv": "gate-rate calibrations",
    "time_scans.csv": "population time scans",
    "traces.csv": "raw heterodyne traces",
    "spam.csv": "SPAM characterisation (basis states prepared, detected with no gate)",
    "pulse_response.csv": "AOM pulse response (a fast photodiode trace of an RF step)",
    "ramsey.csv": "Ramsey and spin-echo characterisation (coherence with a variable wait)",
    "detector_linearity.csv": "detector linearity (photodiode read with and without a "
                              "calibrated attenuator)",
    "thermometry.csv": "sideband thermometry of the gate mode after a variable wait",
}
#: the lab's characterisation experiments: optional tables whose absence is not listed
#: as left out (a campaign without them is analysed as it always was)
CHARACTERISATION_FILES = ("spam.csv", "pulse_response.csv", "ramsey.csv",
                          "detector_linearity.csv", "thermometry.csv")
#: the other files of the folder dpdfit reads: ``budget.toml`` (``dpdfit analyze``'s budget)
OTHER_FILES = ("budget.toml",)


def check_campaign_folder(folder) -> Path:
    """``folder`` as a path, or one InputError naming it: not found, a file, a symbolic
    link loop, a FIFO or device, a folder that cannot be read."""
    name = str(folder)
    try:
        st = os.stat(folder)
    except FileNotFoundError:
        raise InputError("campaign folder not found", file=name) from None
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise InputError("is a symbolic link loop, not a campaign folder",
                             file=name) from None
        raise InputError(f"campaign folder cannot be read ({exc.strerror or exc})",
                         file=name) from None
    if stat.S_ISREG(st.st_mode):
        raise InputError("is a file, not a campaign folder", file=name)
    if not stat.S_ISDIR(st.st_mode):
        raise InputError("is not a folder (a FIFO, device or socket), not a campaign folder",
                         file=name)
    if not os.access(folder, os.R_OK | os.X_OK):
        raise InputError("campaign folder cannot be read (permission denied)", file=name)
    return Path(folder)


class CampaignFolder:
    """A campaign folder read lazily and validated once per file.

    Parameters
    ----------
    folder : path-like
        The folder.  It must exist and hold a readable ``campaign.json``
        (else :class:`~dpdfit.errors.InputError`).
    """

    def __init__(self, folder):
        self.path = check_campaign_folder(folder)
        p = self.path / "campaign.json"
        if not os.path.lexists(p):
            raise InputError("not a campaign folder: campaign.json missing", file=str(self.path))
        raw = _campaign_json(p, self.path)
        self._check_files()
        if not isinstance(raw, dict):
            raise InputError("campaign.json must hold a JSON object", file=str(p))
        self.raw_meta = raw
        self.meta = {**META_DEFAULTS, **raw}
        self.defaults_used = tuple(k for k in META_DEFAULTS if k not in raw)
        for k in META_DEFAULTS:
            try:
                self.meta[k] = float(self.meta[k])
            except (TypeError, ValueError, OverflowError):
                raise InputError(f"key '{k}' must be a number, got {self.meta[k]!r}",
                                 file=str(p)) from None
            if not np.isfinite(self.meta[k]):
                raise InputError(f"key '{k}' must be a finite number, got {self.meta[k]}",
                                 file=str(p))
        if not (1 <= self.meta["order"] <= 40 and self.meta["order"] == int(self.meta["order"])):
            raise InputError(f"key 'order' must be an integer in 1..40, got "
                             f"{self.meta['order']:g}", file=str(p))
        self.meta["order"] = int(self.meta["order"])
        if not isinstance(raw.get("predistortion_table") or {}, dict):
            raise InputError("key 'predistortion_table' must be a JSON object", file=str(p))
        self._table_run = _run_name(raw.get("predistortion_table") or {},
                                    "predistortion_table.amplitude_run", str(p))
        self._phase_run = _run_name(raw, "phase_run_for_model", str(p))
        self._recorded = _recording_times(raw, str(p))

    @functools.cached_property
    def recording_times(self) -> dict:
        """``{"spectra_recorded": Timestamp, "gates_recorded": Timestamp}`` of the keys
        present (UTC), checked against the calibration runs: a time more than
        ``MAX_FUTURE_DAYS`` after the last run's timestamp is refused (InputError
        naming the key)."""
        out = dict(self._recorded)
        if out and self.has("calibration_amplitude.csv"):
            runs = self.amplitude_runs
            if "timestamp" in runs.columns:
                last = runs["timestamp"].max()
                for k, t in out.items():
                    if (t - last) / pd.Timedelta(days=1) > MAX_FUTURE_DAYS:
                        raise InputError(
                            f"key '{k}' ({t.isoformat()}) lies more than a year after the "
                            f"last calibration run ({last.isoformat()})",
                            file=str(self.path / "campaign.json"))
        return out

    def _check_files(self) -> None:
        """Every file of the layout the folder has, and budget.toml: a regular file
        inside the folder, within the size bound (module doc); nothing of it is read."""
        for name in [*FILES, *OTHER_FILES]:
            path = self.path / name
            if name != "campaign.json" and os.path.lexists(path):
                with open_input(path, within=self.path, what="file"):
                    pass

    # ------------------------------------------------------------------ basics
    def file(self, name: str) -> Path:
        """Path of the folder's file ``name`` (whether or not it exists)."""
        return self.path / name

    def has(self, name: str) -> bool:
        """The folder has a file ``name``."""
        return (self.path / name).exists()

    def require(self, name: str, what: str) -> Path:
        """Path of a file an analysis cannot do without (InputError naming it if absent)."""
        path = self.path / name
        if not path.exists():
            raise InputError(f"{what} needs {name}, which is missing", file=str(self.path))
        return path

    @property
    def nu(self) -> float:
        """Sideband detuning ``nu`` of the gate tones from the carrier (Hz), ``nu_hz``."""
        return self.meta["nu_hz"]

    @property
    def xi0_spectra(self) -> float:
        """Gate detuning ``xi0`` of the recorded spectra (Hz), ``xi0_spectra_hz``."""
        return self.meta["xi0_spectra_hz"]

    @property
    def table_run(self) -> str:
        """Amplitude run behind the predistortion table (``latest`` if not named)."""
        return self._table_run

    @property
    def phase_run(self) -> str:
        """The phase run the model uses (``phase_run_for_model``; ``latest`` if not named)."""
        return self._phase_run

    # -------------------------------------------------------------- calibration
    @functools.cached_property
    def amplitude_runs(self) -> pd.DataFrame:
        """Every amplitude calibration run (validated table)."""
        return read_calibration_table(
            self.require("calibration_amplitude.csv", "the calibration"), "amplitude",
            within=self.path)

    @functools.cached_property
    def amplitude_model(self) -> CalibrationData:
        """The amplitude run behind the predistortion table."""
        run = self.table_run if list_runs(self.amplitude_runs) else None
        return calibration_data(self.amplitude_runs, "amplitude", run)

    @functools.cached_property
    def amplitude_run_data(self) -> dict:
        """Every amplitude run, ``{label: CalibrationData}`` (label None: a single run)."""
        return calibration_runs_data(self.amplitude_runs, "amplitude")

    @functools.cached_property
    def phase_runs(self) -> pd.DataFrame | None:
        """Every phase calibration run (validated ``calibration_phase.csv``), None without
        the file."""
        if not self.has("calibration_phase.csv"):
            return None
        return read_calibration_table(self.file("calibration_phase.csv"), "phase",
                                      within=self.path)

    @functools.cached_property
    def phase_model(self) -> CalibrationData | None:
        """The phase run of the model (:attr:`phase_run`), None without a phase file."""
        if self.phase_runs is None:
            return None
        run = self.phase_run if list_runs(self.phase_runs) else None
        return calibration_data(self.phase_runs, "phase", run)

    @functools.cached_property
    def phase_run_data(self) -> dict:
        """Every phase run, ``{label: CalibrationData}`` (empty without a phase file)."""
        return {} if self.phase_runs is None else calibration_runs_data(self.phase_runs,
                                                                        "phase")

    # ------------------------------------------------------------------ spectra
    @functools.cached_property
    def spectra(self) -> pd.DataFrame:
        """Every reading of ``spectra.csv``: ``A, dpd, sideband, n, P_dB, valid, repeat``
        (+ ``snr_db`` when recorded), repeated recordings of a tone as rows of their own
        (:func:`~.spectra.read_spectra`)."""
        return read_spectra(self.require("spectra.csv", "the spectra analysis"),
                            within=self.path)

    @functools.cached_property
    def pooled_spectra(self) -> pd.DataFrame:
        """One row per tone, its repeated recordings pooled (mean linear power, with
        ``n_repeats``): :func:`~.spectra.pool_spectra` of :attr:`spectra`."""
        return pool_spectra(self.spectra)

    # -------------------------------------------------------------------- gates
    @functools.cached_property
    def populations(self) -> pd.DataFrame | None:
        """Validated ``populations.csv`` (``A, dpd, scan, n_even, shots``, see
        :func:`~.counts.read_populations`), None without the file."""
        return read_populations(self.file("populations.csv"), within=self.path) if self.has(
            "populations.csv") else None

    @functools.cached_property
    def parity(self) -> pd.DataFrame | None:
        """Validated ``parity.csv`` (``A, dpd, scan, phase_rad, n_even, shots``, see
        :func:`~.counts.read_parity`), None without the file."""
        return read_parity(self.file("parity.csv"), within=self.path) if self.has(
            "parity.csv") else None

    @functools.cached_property
    def gate_rates(self) -> pd.DataFrame | None:
        """``A, dpd, xi0_khz`` (+ ``xi0_err_khz``): :func:`~.gate_rates.read_gate_rates`,
        each rate checked against ``nu_hz`` and ``xi0_spectra_hz``
        (:func:`~.plausibility.check_gate_rates`)."""
        if not self.has("gate_rates.csv"):
            return None
        df = read_gate_rates(self.file("gate_rates.csv"), within=self.path)
        check_gate_rates(df, self.nu, self.xi0_spectra, str(self.file("gate_rates.csv")),
                         self.defaults_used, str(self.file("campaign.json")))
        return df

    @functools.cached_property
    def time_scans(self) -> pd.DataFrame | None:
        """``A, dpd, t_us, t_s, n00, n11, shots`` (+ ``n01_10``), one row per time point,
        repeated recordings of a point pooled (:func:`~.counts.read_time_scans`)."""
        if not self.has("time_scans.csv"):
            return None
        return read_time_scans(self.file("time_scans.csv"), within=self.path)

    @functools.cached_property
    def traces(self) -> pd.DataFrame | None:
        """The heterodyne traces listed in ``traces.csv`` (``file, A, dpd, fs, fdet, nu,
        xi0``; rates and frequencies in Hz), None without the file.  Each listed trace
        file is checked (:func:`~.traces.check_trace_file`: inside the folder, a regular
        file, its array within the bound), not loaded; a RefusedFileError names the
        row of ``traces.csv`` that lists a file refused."""
        if not self.has("traces.csv"):
            return None
        name = str(self.file("traces.csv"))
        df = read_table(name, ["file", "A", "dpd", "fs", "fdet", "nu", "xi0"],
                        numeric=["A", "dpd", "fs", "fdet", "nu", "xi0"],
                        ranges={"A": (0, 1), "dpd": (0, 1)}, within=self.path)
        for i, listed in enumerate(df["file"]):
            path = self.path / listed
            try:
                check_inside(path, self.path, "trace")
                if os.path.lexists(path):     # else the traces step says it is not found
                    check_trace_file(path, within=self.path)
            except InputError as exc:
                raise RefusedFileError(f"lists a trace dpdfit does not read: {exc}",
                                       file=name, column="file", row=i + 1) from None
        return df

    @functools.cached_property
    def spam(self) -> pd.DataFrame | None:
        """``prepared, n00, n01_10, n11, shots`` (+ ``run``, ``timestamp``), one row per
        prepared state, repeated recordings pooled (:func:`~.spam.read_spam`), None
        without ``spam.csv``."""
        if not self.has("spam.csv"):
            return None
        return read_spam(self.file("spam.csv"), within=self.path)

    @functools.cached_property
    def pulse_response(self) -> pd.DataFrame | None:
        """``t_us, power, A`` (+ ``power_err``, labels) and ``step``, one row per sample
        (:func:`~.pulse_response.read_pulse_response`; ``A`` absent: the time scans'
        amplitude when they have one), None without ``pulse_response.csv``."""
        if not self.has("pulse_response.csv"):
            return None
        ts = self.time_scans if self.has("time_scans.csv") else None
        amps = () if ts is None else np.unique(ts["A"].to_numpy(dtype=float))
        return read_pulse_response(self.file("pulse_response.csv"), within=self.path,
                                   default_A=float(amps[0]) if len(amps) == 1 else None)

    @functools.cached_property
    def ramsey(self) -> pd.DataFrame | None:
        """``sequence, wait_us, wait_s, n00, n01_10, n11, shots`` (+ ``run``,
        ``timestamp``), one row per point, repeated recordings pooled
        (:func:`~.ramsey.read_ramsey`), the waits checked against the error model's
        ``T2_s`` (:func:`~.ramsey.check_ramsey_waits`); None without ``ramsey.csv``."""
        if not self.has("ramsey.csv"):
            return None
        name = self.file("ramsey.csv")
        df = read_ramsey(name, within=self.path)
        em = self.raw_meta.get("error_model")
        stated = isinstance(em, dict) and "T2_s" in em
        try:
            T2 = float(em["T2_s"]) if stated else ERROR_MODEL.T2_s
        except (TypeError, ValueError):
            return df                     # a bad T2_s is the error model reader's to refuse
        check_ramsey_waits(df, T2, str(name), "campaign.json error_model T2_s" if stated
                           else "the paper's T2, campaign.json states none")
        return df

    @functools.cached_property
    def detector_linearity(self) -> pd.DataFrame | None:
        """``A, power, power_attenuated, attenuation_db`` (+ ``power_err``, ``run``,
        ``timestamp``, ``transmission``), one row per reading pair, its ``A`` checked
        against the calibration runs' range
        (:func:`~.detector_linearity.read_detector_linearity`), None without
        ``detector_linearity.csv``."""
        if not self.has("detector_linearity.csv"):
            return None
        try:
            a = self.amplitude_runs["A"].to_numpy(dtype=float)
            a_range = (float(a.min()), float(a.max()))
        except InputError:          # no readable calibration: its own reader says so
            a_range = None
        return read_detector_linearity(self.file("detector_linearity.csv"), within=self.path,
                                       a_range=a_range)

    @functools.cached_property
    def thermometry(self) -> pd.DataFrame | None:
        """``wait_us, sideband, n_bright, shots`` (+ ``run``, ``timestamp``), one row per
        point (wait, sideband), repeated recordings pooled
        (:func:`~.thermometry.read_thermometry`), None without ``thermometry.csv``."""
        if not self.has("thermometry.csv"):
            return None
        return read_thermometry(self.file("thermometry.csv"), within=self.path)

    def check_plausible(self) -> None:
        """Read every table the folder has and raise the first
        :class:`~dpdfit.errors.ImplausibleValueError` (a unit slip,
        :mod:`~dpdfit.recordings.plausibility`): such a campaign is refused as a whole.
        A file that is malformed is left to the analyses that read it, except
        ``time_scans.csv``, ``spam.csv``, ``pulse_response.csv``, ``ramsey.csv`` and
        ``detector_linearity.csv`` (counts above the shots, say), which no analysis of its
        own reads: they are refused here, at once, not after every analysis ran."""
        for name in ("amplitude_runs", "phase_runs", "spectra", "populations", "parity",
                     "gate_rates", "time_scans", "traces", "spam", "pulse_response", "ramsey",
                     "detector_linearity", "thermometry"):
            try:
                getattr(self, name)
            except InputError as exc:
                if isinstance(exc, (ImplausibleValueError, RefusedFileError)) or (
                        name in ("time_scans", "spam", "pulse_response", "ramsey",
                                 "detector_linearity", "thermometry")):
                    raise

    # -------------------------------------------------------------- left out
    def left_out(self, consequences: dict | None = None) -> list[str]:
        """What is absent from the folder, one line each (nothing if complete): optional
        files, optional columns of the files present (``consequences``:
        :func:`~dpdfit.recordings.columns.missing_column_lines`), defaulted campaign.json keys."""
        out = [f"{name} absent ({what})" for name, what in FILES.items()
               if name not in ("campaign.json", "calibration_amplitude.csv",
                               *CHARACTERISATION_FILES)
               and not self.has(name)]
        for table in CAMPAIGN_TABLES:          # a file absent lacks no column
            out += missing_column_lines(self.file(f"{table}.csv"), table, consequences,
                                        within=self.path)
        if self.defaults_used:
            out.append("campaign.json: default for " + ", ".join(
                f"{k} = {META_DEFAULTS[k]:g}" for k in self.defaults_used))
        if "error_model" not in self.raw_meta:
            out.append("campaign.json has no error_model: paper values with wide priors")
        return out

    def __repr__(self) -> str:
        return f"CampaignFolder({os.fspath(self.path)!r})"


def _campaign_json(path: Path, folder: Path):
    """The JSON value of ``campaign.json`` (read inside ``folder``, at most
    :data:`~dpdfit.core.defaults.MAX_JSON_BYTES` and
    :data:`~dpdfit.core.defaults.MAX_JSON_DEPTH` levels deep); an InputError naming it
    otherwise."""
    return read_input_json(path, within=folder, what="campaign.json",
                           not_json="campaign.json is not valid JSON")


def _run_name(raw: dict, key: str, path: str) -> str:
    """The run label under ``key`` (dotted: the last part is looked up in ``raw``):
    ``latest`` when absent or null, else a string or a whole number as the run column
    holds it; any other JSON value is refused naming the key (never looked up as a run)."""
    v = raw.get(key.rpartition(".")[2])
    if v is None:
        return "latest"
    if isinstance(v, str) or (isinstance(v, int) and not isinstance(v, bool)):
        return str(v)
    raise InputError(f"key '{key}' must be a run label (a string such as \"latest\" or "
                     f"\"R001\"), got a JSON {json_kind(v)}", file=path)


def _recording_times(raw: dict, path: str) -> dict:
    """The recording times of ``campaign.json`` (module doc), parsed and ordered."""
    out = {}
    for k in RECORDING_KEYS:
        if raw.get(k) is None:
            continue
        v = raw[k]
        try:
            if not isinstance(v, str):
                raise ValueError
            t = pd.Timestamp(datetime.datetime.fromisoformat(v.strip()))
        except (ValueError, TypeError, OverflowError):
            raise InputError(f"key '{k}' must be an ISO 8601 date/time "
                             f"(e.g. 2026-03-01T14:30:00), got {v!r}", file=path) from None
        out[k] = t.tz_localize("UTC") if t.tzinfo is None else t.tz_convert("UTC")
    if len(out) == 2 and out["gates_recorded"] < out["spectra_recorded"]:
        raise InputError("key 'gates_recorded' lies before 'spectra_recorded' (the layout: "
                         "the spectra characterise the drive, then the gates are recorded)",
                         file=path)
    return out
