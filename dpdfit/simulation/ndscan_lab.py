"""A campaign's tables as the ndscan runs a lab records them, numbered and timed in order.

:class:`NdscanLab` holds the tables and writes each run as an ARTIQ results file
(:func:`~dpdfit.simulation.artiq_results_file.write_results_file`) with the next rid.
The runs every layout shares: one per calibration run (:func:`write_calibration_runs`),
the spectra (:func:`write_spectra_runs`), and the ndscan set's gate runs
(:func:`write_ndscan_gate_runs`), SPAM characterisations (:func:`write_spam_runs`),
AOM pulse responses (:func:`write_pulse_runs`), Ramsey scans (:func:`write_ramsey_runs`)
and detector linearity characterisations (:func:`write_linearity_runs`);
:mod:`dpdfit.simulation.artiq_results` writes whole campaigns with them and
:mod:`dpdfit.simulation.recorded_artiq` continues one.
"""

from __future__ import annotations

import io
import itertools
import os
from datetime import datetime
from pathlib import Path

import numpy as np
import pandas as pd

from dpdfit.errors import DpdfitError, InputError
from dpdfit.recordings.campaign_folder import CHARACTERISATION_FILES, CampaignFolder
from dpdfit.recordings.columns import CAMPAIGN_TABLES
from dpdfit.recordings.csv_text import parse_csv_strings
from dpdfit.recordings.input_files import read_input_bytes
from dpdfit.recordings.pulse_response import step_labels
from dpdfit.recordings.mapping_values import check_campaign_types
from dpdfit.simulation.artiq_results_file import (axis, channel, ndscan_datasets, stored_in_si,
                                                  write_results_file)

__all__ = ["NdscanLab", "read_campaign_table", "read_campaign_json", "campaign_meta", "epoch", "write_calibration_runs", "write_spectra_runs", "duration_axis",
           "time_scan_runs", "count_channels", "write_ndscan_gate_runs", "SPAM_EXPERIMENT",
           "spam_code", "spam_runs", "write_spam_runs", "write_campaign_spam_runs",
           "PULSE_EXPERIMENT", "write_pulse_runs", "write_campaign_pulse_runs",
           "RAMSEY_EXPERIMENT", "RAMSEY_CODES", "ramsey_runs", "write_ramsey_runs",
           "write_campaign_ramsey_runs", "LINEARITY_EXPERIMENT", "linearity_runs",
           "write_linearity_runs", "write_campaign_linearity_runs"]

#: the ndscan fragment of the lab's SPAM characterisation (its results files end
#: ``-SpamCharacterisation.h5``)
SPAM_EXPERIMENT = "lab.characterisation.SpamCharacterisation"
#: the ndscan fragment of the lab's AOM pulse response (``-PulseResponse.h5``)
PULSE_EXPERIMENT = "lab.characterisation.PulseResponse"
#: the ndscan fragment of the lab's Ramsey and spin-echo scan (its results files end
#: ``-RamseyEcho.h5``)
RAMSEY_EXPERIMENT = "lab.characterisation.RamseyEcho"
#: the codes of the Ramsey scan's axis ``sequence`` (the mapping's labels turn them back)
RAMSEY_CODES = {"ramsey": 0, "echo": 1}
#: the ndscan fragment of the lab's detector linearity characterisation (its results
#: files end ``-DetectorLinearity.h5``)
LINEARITY_EXPERIMENT = "lab.characterisation.DetectorLinearity"


def read_campaign_table(folder, table: str) -> pd.DataFrame:
    """The campaign's table ``table`` (``folder/<table>.csv``) as pandas reads it, read
    through :func:`~dpdfit.recordings.input_files.read_input_bytes`: a regular file inside
    the folder, size bounded (a FIFO or a link out of the folder refused, not read).

    Its header and every row are checked first by the parser every campaign table goes
    through (:func:`~dpdfit.recordings.csv_text.parse_csv_strings`: a row wider than the
    header, a repeated column name, a NUL, text that is not UTF-8 or a cell a spreadsheet
    would run are refused naming the file, column and row); pandas then reads the same
    bytes with the types it infers, as the simulator wrote them."""
    path = Path(folder, f"{table}.csv")
    data = read_input_bytes(path, within=folder, what="campaign table")
    parse_csv_strings(data, str(path))
    return pd.read_csv(io.BytesIO(data), comment="#")


def read_campaign_json(folder) -> dict:
    """The campaign's ``campaign.json`` as
    :class:`~dpdfit.recordings.campaign_folder.CampaignFolder` reads and checks it (inside
    the folder, bounded; its numbers, times
    and run labels), its other keys checked by the types a mapping's ``[campaign]`` takes
    (:func:`~dpdfit.recordings.mapping_values.check_campaign_types`): the new
    recordings' mapping carries them.  An InputError naming the key otherwise."""
    return campaign_meta(CampaignFolder(folder))


def campaign_meta(folder: CampaignFolder) -> dict:
    """The campaign.json of ``folder`` as :func:`read_campaign_json` checks it."""
    check_campaign_types(folder.raw_meta, _FirstRefusal(str(folder.file("campaign.json"))))
    return folder.raw_meta


class _FirstRefusal:
    """The error sink :func:`check_campaign_types` reports to, raising the first refusal
    as one line naming campaign.json (a mapping collects them; a campaign.json is one
    file, refused at its first wrong key)."""

    def __init__(self, path: str):
        self.path = path

    def bad(self, key: str, message: str, *where) -> None:
        key = key.removeprefix("campaign.")
        # the error model's own refusal names its key already ("error_model key 'T2_s' ...")
        text = message if message.startswith(key) else f"key '{key}' {message}"
        raise InputError(text, file=self.path)


def epoch(iso: str) -> float:
    """The POSIX time of an ISO 8601 timestamp (a campaign's recording times)."""
    return datetime.fromisoformat(iso).timestamp()


class NdscanLab:
    """A campaign's tables (``t``, name -> DataFrame; ``campaign``: its campaign.json), and
    the runs written from them into ``out`` (``rid``: the last run's, in order)."""

    def __init__(self, campaign_dir, out):
        # a characterisation table (spam.csv) is optional: empty when the campaign has none
        self.t = {n: read_campaign_table(campaign_dir, n)
                  if f"{n}.csv" not in CHARACTERISATION_FILES
                  or os.path.lexists(Path(campaign_dir, f"{n}.csv")) else pd.DataFrame()
                  for n in CAMPAIGN_TABLES}
        self.campaign = read_campaign_json(campaign_dir)
        self.out, self.rid, self.last = Path(out), 0, None

    def run(self, class_name, start, datasets, arguments=None, metadata=None):
        """Write the next run (``rid + 1``) of experiment ``class_name``, started at
        ``start`` (s since the epoch), as a results file in ``out``."""
        self.rid += 1
        self.last = start if self.last is None else max(self.last, start)
        write_results_file(self.out, self.rid, class_name, start, datasets, arguments=arguments,
                           metadata=metadata)

    def scan(self, fqn, start, axes, channels, arguments=None, overrides=None, repeats=1, **kw):
        """An ndscan run of fragment ``fqn``; ``overrides``: parameter name -> value."""
        rid = self.rid + 1
        over = {f"{fqn}.{k}": [{"path": "*", "value": v}] for k, v in (overrides or {}).items()}
        gens = [{"type": "list", "fqn": f"{fqn}.{a['name']}", "path": "*",
                 "range": {"values": list(dict.fromkeys(a["values"].tolist()))}} for a in axes]
        scan = {"axes": gens, "num_repeats": repeats, "randomise_order_globally": False}
        params = {"instances": {"": [fqn]}, "scan": scan, "overrides": over}
        ds = ndscan_datasets(rid, fqn, axes, channels, seed=rid * 7919 % 2**31, **kw)
        self.run(fqn.rsplit(".", 1)[1], start, ds, {"ndscan_params": params, **(arguments or {})})



def write_calibration_runs(lab: NdscanLab, percent: bool) -> None:
    """One run per calibration run (amplitude runs first: rid = run number), at its timestamp;
    with ``percent`` the amplitude calibration's axis is in % (if that round-trips exactly)."""
    percent = percent and stored_in_si(lab.t["calibration_amplitude"]["A"], 100.0)[1] == 100.0
    for table, fqn in (("calibration_amplitude", "lab.calib.AmplitudeCalibration"),
                       ("calibration_phase", "lab.calib.PhaseCalibration")):
        runs = lab.t[table].groupby("run", sort=False)
        for label, rows in sorted(runs, key=lambda r: epoch(r[1]["timestamp"].iloc[0])):
            ax = axis("amplitude", rows["A"].to_numpy(float))
            if table == "calibration_amplitude":
                if percent:
                    ax = axis("amplitude", ax["values"] * 100.0, unit="%")
                ch = {"pd_power": channel(rows["power"]),
                      "pd_power_err": channel(rows["power_err"])}
            else:
                ch = {"phase": channel(rows["phase_rad"], "rad"),
                      "phase_err": channel(rows["phase_err"], "rad")}
            lab.scan(fqn, epoch(rows["timestamp"].iloc[0]), [ax], ch, {"label": label})


def write_spectra_runs(lab: NdscanLab, per_amplitude: bool, step: float) -> None:
    """One file per dpd (amplitude an axis, dpd an argument) or per (A, dpd) (amplitude an
    argument, dpd a parameter override); axes sideband x order.  A spectrum recorded
    again (repeated rows of a tone) is a further run, after the first: the import reads
    the runs in that order, so the k-th row of a tone is again its k-th repeat."""
    clock = itertools.count(epoch(lab.campaign["spectra_recorded"]), step)
    cols = (("tone_power", "P_dB", "dB"), ("valid", "valid", ""), ("snr", "snr_db", "dB"))
    sp = lab.t["spectra"]
    rep = sp.groupby(["A", "dpd", "sideband", "n"], sort=False).cumcount().rename("_repeat")
    keys = (["A", "dpd"] if per_amplitude else ["dpd"])
    for key, rows in sp.groupby([sp[k] for k in keys] + [rep]):
        key = key[:-1]
        axes = [axis("sideband", (rows["sideband"] == "blue").to_numpy(np.int64)),
                axis("order", rows["n"].to_numpy(np.int64))]
        ch = {name: channel(rows[col], unit) for name, col, unit in cols if col in rows}
        args, over = {"amplitude": float(key[0])}, {"dpd": int(key[-1])}
        if not per_amplitude:
            args, over = over, None
            axes.insert(0, axis("amplitude", rows["A"].to_numpy(float)))
        lab.scan("lab.spectra.HeterodyneSpectrum", next(clock), axes, ch, args, over)


def duration_axis(rows: pd.DataFrame) -> dict:
    """The time scan's axis ``duration`` of ``rows['t_us']``, stored in s when that is exact."""
    stored, scale = stored_in_si(rows["t_us"], 1e-6)
    return axis("duration", stored, unit="us", scale=scale)


def time_scan_runs(lab: NdscanLab):
    """The time scans, one run per (A, dpd) and repeat: a point recorded again (the same
    ``A, dpd, t_us``) belongs to a further run, as a lab repeats a scan."""
    ts = lab.t["time_scans"]
    rep = ts.groupby(["A", "dpd", "t_us"], sort=False).cumcount().rename("_repeat")
    return ts.groupby([ts["A"], ts["dpd"], rep])


def count_channels(rows: pd.DataFrame, cols) -> dict:
    """An integer result channel per count column ``cols`` of ``rows``."""
    return {c: channel(rows[c].to_numpy(np.int64)) for c in cols}


def write_ndscan_gate_runs(lab: NdscanLab) -> None:
    """Set 1's gate runs: gate rates, populations per dpd, parity and time scans per (A, dpd)."""
    clock = itertools.count(epoch(lab.campaign["gates_recorded"]), 300.0)
    g, ch = lab.t["gate_rates"], {}
    for name, col in (("xi0", "xi0_khz"), ("xi0_err", "xi0_err_khz")):
        stored, scale = stored_in_si(g[col], 1e3)
        ch[name] = channel(stored, "kHz", scale)
    axes = [axis("amplitude", g["A"].to_numpy(float)), axis("dpd", g["dpd"].to_numpy(np.int64))]
    lab.scan("lab.gates.GateRateCalibration", next(clock), axes, ch)
    for dpd, rows in lab.t["populations"].groupby("dpd"):
        rows = rows.sort_values(["scan", "A"], kind="stable")
        lab.scan("lab.gates.PopulationScan", next(clock), [axis("amplitude", rows["A"])],
                 count_channels(rows, ("n00", "n01_10", "n11", "n_even", "shots")),
                 {"dpd": int(dpd)}, repeats=rows["scan"].nunique())
    for (a, dpd), rows in lab.t["parity"].groupby(["A", "dpd"]):
        rows = rows.sort_values("scan", kind="stable")
        lab.scan("lab.gates.ParityScan", next(clock), [axis("phase", rows["phase_rad"], "rad")],
                 count_channels(rows, ("n_even", "shots")),
                 {"amplitude": float(a), "dpd": int(dpd)}, repeats=rows["scan"].nunique())
    for (a, dpd, _), rows in time_scan_runs(lab):
        if rows["shots"].nunique() != 1:
            raise DpdfitError(f"time_scans: shots vary at A = {a}, dpd = {dpd}; "
                              "the mapping expects them constant per (A, dpd)")
        args = {"amplitude": float(a), "dpd": int(dpd), "num_shots": int(rows["shots"].iloc[0])}
        lab.scan("lab.gates.TimeScan", next(clock), [duration_axis(rows)],
                 count_channels(rows, ("n00", "n01_10", "n11")), args)


def spam_code(prepared) -> np.ndarray:
    """The prepared basis states (``00`` .. ``11``, the first character the first ion) as
    the integer codes of the SPAM experiment's axis ``prepared``: each state read as a
    binary number (``00`` -> 0, ``01`` -> 1, ``10`` -> 2, ``11`` -> 3), which the
    mapping's ``labels`` turn back into the text ``spam.csv`` records."""
    # pandas may have read 00 as the number 0; a lab may write |00>
    text = pd.Series(prepared).astype(str).str.strip().str.strip("|>").str.zfill(2)
    bad = [s for s in text if s not in ("00", "01", "10", "11")]
    if bad:
        raise DpdfitError(f"spam: prepared state {bad[0]!r} is not a basis state "
                          "(00, 01, 10, 11)")
    return np.array([int(s, 2) for s in text], dtype=np.int64)


def spam_runs(rows: pd.DataFrame) -> list:
    """The SPAM rows as the runs a lab records them in, in order: a run prepares each
    state once with one number of shots, so a state prepared again (or other shots)
    begins the next run.  Each run's rows, consecutive as in ``rows``."""
    if not len(rows):
        return []
    codes, shots = spam_code(rows["prepared"]), rows["shots"].to_numpy(np.int64)
    starts, seen = [0], set()
    for i, (c, n) in enumerate(zip(codes, shots)):
        if c in seen or (i and n != shots[starts[-1]]):
            starts.append(i)
            seen = set()
        seen.add(c)
    return [rows.iloc[a:b] for a, b in zip(starts, starts[1:] + [len(rows)])]


def write_spam_runs(lab: NdscanLab, clock) -> None:
    """One run of :data:`SPAM_EXPERIMENT` per SPAM recording (:func:`spam_runs`) of
    ``lab.t['spam']``, started at the times ``clock`` gives: the prepared state the scan
    axis (:func:`spam_code`), the detected outcomes result channels, the shots the
    argument ``num_shots``."""
    for rows in spam_runs(lab.t["spam"]):
        lab.scan(SPAM_EXPERIMENT, next(clock), [axis("prepared", spam_code(rows["prepared"]))],
                 count_channels(rows, ("n00", "n01_10", "n11")),
                 {"num_shots": int(rows["shots"].iloc[0])})


def write_campaign_spam_runs(lab: NdscanLab) -> None:
    """The campaign's SPAM recordings (``spam.csv``, if it has one), 300 s apart after
    its last run: a characterisation taken once the gates were recorded."""
    if len(lab.t["spam"]):
        write_spam_runs(lab, itertools.count(lab.last + 300.0, 300.0))


def write_pulse_runs(lab: NdscanLab, clock) -> None:
    """One run of :data:`PULSE_EXPERIMENT` per trace (step,
    :func:`~dpdfit.recordings.pulse_response.step_labels`) of
    ``lab.t['pulse_response']``, started at the times ``clock`` gives: the time after
    the step the scan axis ``delay`` (shown in us, stored in s when that is exact), the
    photodiode's reading and its error result channels, the step's amplitude and the
    trace's label the arguments ``amplitude`` and ``label``."""
    rows = lab.t["pulse_response"]
    if not len(rows):
        return
    for k, (_, trace) in enumerate(rows.groupby(step_labels(rows), sort=True)):
        stored, scale = stored_in_si(trace["t_us"], 1e-6)
        ch = {"pd_power": channel(trace["power"].to_numpy(float))}
        if "power_err" in trace.columns:
            ch["pd_power_err"] = channel(trace["power_err"].to_numpy(float))
        label = str(trace["run"].iloc[0]) if "run" in trace.columns else f"pulse{k + 1}"
        lab.scan(PULSE_EXPERIMENT, next(clock), [axis("delay", stored, unit="us", scale=scale)],
                 ch, {"amplitude": float(trace["A"].iloc[0]), "label": label})


def write_campaign_pulse_runs(lab: NdscanLab) -> None:
    """The campaign's AOM pulse responses (``pulse_response.csv``, if it has one), 300 s
    apart after its last run: a characterisation taken once the rest was recorded."""
    if len(lab.t["pulse_response"]):
        write_pulse_runs(lab, itertools.count(lab.last + 300.0, 300.0))


def ramsey_runs(rows: pd.DataFrame) -> list:
    """The Ramsey rows as the runs a lab records them in, in order: a run takes each
    ``(sequence, wait_us)`` once with one number of shots, so a point taken again (or
    other shots) begins the next run.  Each run's rows, consecutive as in ``rows``."""
    if not len(rows):
        return []
    keys = list(zip(rows["sequence"], rows["wait_us"].to_numpy(float)))
    shots = rows["shots"].to_numpy(np.int64)
    starts, seen = [0], set()
    for i, (k, n) in enumerate(zip(keys, shots)):
        if k in seen or (i and n != shots[starts[-1]]):
            starts.append(i)
            seen = set()
        seen.add(k)
    return [rows.iloc[a:b] for a, b in zip(starts, starts[1:] + [len(rows)])]


def write_ramsey_runs(lab: NdscanLab, clock) -> None:
    """One run of :data:`RAMSEY_EXPERIMENT` per Ramsey scan (:func:`ramsey_runs`) of
    ``lab.t['ramsey']``, started at the times ``clock`` gives: axes ``sequence`` (a code,
    :data:`RAMSEY_CODES`) and ``wait`` (shown in us, stored in s when that is exact), the
    detected outcomes result channels, the shots the argument ``num_shots``."""
    for rows in ramsey_runs(lab.t["ramsey"]):
        codes = np.array([RAMSEY_CODES[str(x).strip().lower()] for x in rows["sequence"]],
                         dtype=np.int64)
        stored, scale = stored_in_si(rows["wait_us"], 1e-6)
        lab.scan(RAMSEY_EXPERIMENT, next(clock),
                 [axis("sequence", codes), axis("wait", stored, unit="us", scale=scale)],
                 count_channels(rows, ("n00", "n01_10", "n11")),
                 {"num_shots": int(rows["shots"].iloc[0])})


def write_campaign_ramsey_runs(lab: NdscanLab) -> None:
    """The campaign's Ramsey scans (``ramsey.csv``, if it has one), 300 s apart after its
    last run: a characterisation taken once the gates were recorded."""
    if len(lab.t["ramsey"]):
        write_ramsey_runs(lab, itertools.count(lab.last + 300.0, 300.0))


def linearity_runs(rows: pd.DataFrame) -> list:
    """The detector linearity rows as the runs a lab records them in, in order: a run
    reads each drive once with one attenuator, so a drive read again (or another
    attenuator) begins the next run.  Each run's rows, consecutive as in ``rows``."""
    if not len(rows):
        return []
    A, att = rows["A"].to_numpy(float), rows["attenuation_db"].to_numpy(float)
    starts, seen = [0], set()
    for i, (a, d) in enumerate(zip(A, att)):
        if a in seen or (i and d != att[starts[-1]]):
            starts.append(i)
            seen = set()
        seen.add(a)
    return [rows.iloc[a:b] for a, b in zip(starts, starts[1:] + [len(rows)])]


def write_linearity_runs(lab: NdscanLab, clock) -> None:
    """One run of :data:`LINEARITY_EXPERIMENT` per detector linearity recording
    (:func:`linearity_runs`) of ``lab.t['detector_linearity']``, started at the times
    ``clock`` gives: the drive the scan axis ``amplitude``, the readings without and with
    the attenuator (and ``power_err``, when recorded) result channels, the attenuator
    the argument ``attenuation_db``."""
    for rows in linearity_runs(lab.t["detector_linearity"]):
        ch = {"pd_power": channel(rows["power"]),
              "pd_power_attenuated": channel(rows["power_attenuated"])}
        if "power_err" in rows:
            ch["pd_power_err"] = channel(rows["power_err"])
        lab.scan(LINEARITY_EXPERIMENT, next(clock), [axis("amplitude", rows["A"].to_numpy(float))],
                 ch, {"attenuation_db": float(rows["attenuation_db"].iloc[0])})


def write_campaign_linearity_runs(lab: NdscanLab) -> None:
    """The campaign's detector linearity recordings (``detector_linearity.csv``, if it has
    one), 300 s apart after its last run."""
    if len(lab.t["detector_linearity"]):
        write_linearity_runs(lab, itertools.count(lab.last + 300.0, 300.0))
