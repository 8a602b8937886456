"""New recordings of a campaign written as ARTIQ results files, as the lab would have taken them.

The rows a stand-in recording added (:func:`~dpdfit.simulation.recorded_schedule.record_further`)
are written with the ndscan layout of :func:`~dpdfit.simulation.artiq_results.write_ndscan_campaign`
(its runs, :mod:`~dpdfit.simulation.ndscan_lab`, and its mapping), continuing the campaign
as its own files would have been numbered: an amplitude run's rid is its run number (the
mapping labels it ``R{rid:03d}``), every other file's rid comes after every rid the
campaign's files would have, and the spectra, gate and SPAM files start after the
campaign's last file (calibration runs start at their recorded time, which the mapping
reads as their timestamp).  A SPAM characterisation is one run per recording of the
prepared states (:func:`~dpdfit.simulation.ndscan_lab.write_spam_runs`), imported by the
mapping's ``[[spam]]`` into ``spam.csv``; an AOM pulse response is one run per trace
(:func:`~dpdfit.simulation.ndscan_lab.write_pulse_runs`), imported by its
``[[pulse_response]]``; a Ramsey scan is one run
(:func:`~dpdfit.simulation.ndscan_lab.write_ramsey_runs`), imported by ``[[ramsey]]``
into ``ramsey.csv``; a detector linearity characterisation is one run per recording
(:func:`~dpdfit.simulation.ndscan_lab.write_linearity_runs`), imported by
``[[detector_linearity]]``.  The mapping's ``[campaign]`` table is the
campaign's ``campaign.json`` (without its recording times), so that the new files are
seen as the same campaign's; tables without new rows are left out of it (a glob that
matches nothing is an import error), so it is read as the mapping of further
recordings (``read_mapping(path, partial=True)``, as ``dpdfit add`` reads it).
"""

from __future__ import annotations

import itertools
import os
import tomllib
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pandas as pd

from dpdfit.errors import InputError
from dpdfit.recordings.columns import CAMPAIGN_TABLES
from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.recordings.imported_check import READERS
from dpdfit.recordings.input_files import read_input_json
from dpdfit.recordings.outputs import staged_folder
from dpdfit.recordings.schedule import read_schedule
from dpdfit.simulation.artiq_results import copy_mapping
from dpdfit.simulation.artiq_results_file import axis, channel, stored_in_si
from dpdfit.simulation.campaign import CampaignConfig
from dpdfit.simulation.further_recordings import schedule_measurements
from dpdfit.simulation.ndscan_lab import (NdscanLab, count_channels, duration_axis, epoch,
                                          campaign_meta, read_campaign_table,
                                          time_scan_runs, write_calibration_runs,
                                          write_campaign_linearity_runs,
                                          write_campaign_pulse_runs,
                                          write_campaign_ramsey_runs,
                                          write_campaign_spam_runs, write_ndscan_gate_runs,
                                          write_linearity_runs, write_pulse_runs,
                                          write_ramsey_runs, write_spam_runs,
                                          write_spectra_runs)
from dpdfit.simulation.ndscan_thermometry import (write_campaign_thermometry_runs,
                                                  write_thermometry_runs)
from dpdfit.simulation.recorded_schedule import StandInRecording, record_further
from dpdfit.simulation.scheduled_points import check_recorded_as_scheduled

__all__ = ["campaign_files_end", "write_recorded_results", "read_campaign_tables",
           "record_schedule"]

#: seconds between the campaign's last file and the first new spectra or gate file
_AFTER = 300.0
#: the new files' mapping: a line on what it imports, above the shipped one's comments
_HEADER = ("# The new recordings of '{name}' only (dpdfit write-artiq-results --schedule):\n"
           "# add them to a copy of the campaign: dpdfit add CAMPAIGN mapping.toml -o OUT\n"
           "# (a mapping of some tables only: read_mapping(path, partial=True)).\n")


class _Counted(NdscanLab):
    """A campaign's tables numbered as its ndscan files would be, without writing them."""

    def __init__(self, tables: dict, campaign: dict, out=None, rid: int = 0):
        self.t, self.campaign, self.out, self.rid = tables, campaign, out, rid
        self.last = None

    def run(self, class_name, start, datasets, arguments=None, metadata=None):
        if self.out is not None:
            super().run(class_name, start, datasets, arguments, metadata)
        else:
            self.rid += 1
        self.last = start if self.last is None else max(self.last, start)


def campaign_files_end(tables: dict, campaign: dict) -> tuple:
    """``(last rid, last start time)`` of a campaign written as ndscan files
    (:func:`~dpdfit.simulation.artiq_results.write_ndscan_campaign`): the rids and times
    its new recordings continue after.  ``tables``: name -> DataFrame of the campaign."""
    lab = _Counted({t: tables.get(t, pd.DataFrame()) for t in CAMPAIGN_TABLES}, campaign)
    write_calibration_runs(lab, percent=False)
    if len(lab.t["spectra"]):
        write_spectra_runs(lab, False, 240.0)
    if all(len(lab.t[t]) for t in ("gate_rates", "populations", "parity", "time_scans")):
        write_ndscan_gate_runs(lab)
    write_campaign_spam_runs(lab)
    write_campaign_pulse_runs(lab)
    write_campaign_ramsey_runs(lab)
    write_campaign_linearity_runs(lab)
    write_campaign_thermometry_runs(lab)
    times = [epoch(campaign[k]) for k in ("spectra_recorded", "gates_recorded")
             if k in campaign]
    return lab.rid, max([t for t in (lab.last,) if t is not None] + times)


def _iso(epoch: float) -> str:
    return datetime.fromtimestamp(epoch, timezone.utc).isoformat(timespec="seconds")


def _amplitude_runs(lab: _Counted, rows: pd.DataFrame) -> None:
    """One file per new amplitude run, rid = its run number, at its recorded time."""
    after = lab.rid
    for label, run in rows.groupby("run", sort=False):
        number = int(str(label).lstrip("R"))
        if number <= 0:
            raise InputError(f"calibration_amplitude: run label {label!r} is not R<number>")
        lab.rid = number - 1
        ch = {"pd_power": channel(run["power"]), "pd_power_err": channel(run["power_err"])}
        lab.scan("lab.calib.AmplitudeCalibration", epoch(run["timestamp"].iloc[0]),
                 [axis("amplitude", run["A"].to_numpy(float))], ch, {"label": label})
    lab.rid = after


def _phase_runs(lab: _Counted, rows: pd.DataFrame) -> None:
    for label, run in rows.groupby("run", sort=False):
        ch = {"phase": channel(run["phase_rad"], "rad"),
              "phase_err": channel(run["phase_err"], "rad")}
        lab.scan("lab.calib.PhaseCalibration", epoch(run["timestamp"].iloc[0]),
                 [axis("amplitude", run["A"].to_numpy(float))], ch, {"label": label})


def _gates(lab: _Counted, clock) -> None:
    """The new gate rows: a gate-rate file (a new setting's), populations per dpd, parity
    per (A, dpd) and time scans per (A, dpd) and repeat, as the ndscan set writes them."""
    t = lab.t
    if len(t["gate_rates"]):
        g, ch = t["gate_rates"], {}
        for name, col in (("xi0", "xi0_khz"), ("xi0_err", "xi0_err_khz")):
            stored, scale = stored_in_si(g[col], 1e3)
            ch[name] = channel(stored, "kHz", scale)
        axes = [axis("amplitude", g["A"].to_numpy(float)),
                axis("dpd", g["dpd"].to_numpy(np.int64))]
        lab.scan("lab.gates.GateRateCalibration", next(clock), axes, ch)
    for dpd, rows in t["populations"].groupby("dpd") if len(t["populations"]) else ():
        rows = rows.sort_values(["scan", "A"], kind="stable")
        lab.scan("lab.gates.PopulationScan", next(clock), [axis("amplitude", rows["A"])],
                 count_channels(rows, ("n00", "n01_10", "n11", "n_even", "shots")),
                 {"dpd": int(dpd)}, repeats=rows["scan"].nunique())
    for (a, dpd), rows in t["parity"].groupby(["A", "dpd"]) if len(t["parity"]) else ():
        rows = rows.sort_values("scan", kind="stable")
        lab.scan("lab.gates.ParityScan", next(clock), [axis("phase", rows["phase_rad"], "rad")],
                 count_channels(rows, ("n_even", "shots")),
                 {"amplitude": float(a), "dpd": int(dpd)}, repeats=rows["scan"].nunique())
    for (a, dpd, _), rows in time_scan_runs(lab) if len(t["time_scans"]) else ():
        args = {"amplitude": float(a), "dpd": int(dpd), "num_shots": int(rows["shots"].iloc[0])}
        lab.scan("lab.gates.TimeScan", next(clock), [duration_axis(rows)],
                 count_channels(rows, ("n00", "n01_10", "n11")), args)


def _mapping_text(campaign: dict, tables, tmp: Path) -> str:
    """The shipped ndscan mapping with the campaign's constants, its sources cut to
    ``tables``."""
    text = copy_mapping("ndscan_campaign.toml", campaign, tmp, tables).read_text()
    out = _HEADER.format(name=campaign.get("name", "campaign")) + text
    got = {k for k, v in tomllib.loads(out).items() if isinstance(v, list)}
    if got != set(tables):                     # the shipped mapping's layout changed
        raise RuntimeError(f"mapping sources {sorted(got)} are not {sorted(tables)}")
    return out


def write_recorded_results(new: dict, campaign_tables: dict, campaign: dict, out_dir) -> Path:
    """Write new rows of a campaign as ARTIQ results files plus ``OUT_DIR/mapping.toml``.

    Parameters
    ----------
    new : dict
        Table name -> the new rows (:attr:`StandInRecording.tables`).
    campaign_tables : dict
        The campaign's tables (their files' rids and times are continued after).
    campaign : dict
        The campaign's ``campaign.json`` (the mapping's ``[campaign]``).
    out_dir : path-like
        A new folder (written whole or not at all).

    Returns
    -------
    pathlib.Path
        ``out_dir/mapping.toml``; its import (``read_mapping(path, partial=True)``, as
        ``dpdfit add`` reads it) gives the new rows back bit for bit (``scan`` numbered 1, 2, ... per setting, as the schedule's repeats; adding
        them to the campaign continues the campaign's numbers).
    """
    if not new:
        raise InputError("the recording added no rows: nothing to write")
    last_rid, last_time = campaign_files_end(campaign_tables, campaign)
    out = Path(out_dir)
    with staged_folder(out) as tmp:
        t = {name: new.get(name, pd.DataFrame()) for name in CAMPAIGN_TABLES}
        lab = _Counted(t, {**campaign, "spectra_recorded": _iso(last_time + _AFTER)}, tmp,
                       rid=last_rid)
        if len(t["calibration_amplitude"]):
            _amplitude_runs(lab, t["calibration_amplitude"])
        if len(t["calibration_phase"]):
            _phase_runs(lab, t["calibration_phase"])
        if len(t["spectra"]):
            write_spectra_runs(lab, False, 240.0)
        clock = itertools.count(max(lab.last or last_time, last_time) + _AFTER, 300.0)
        _gates(lab, clock)
        if len(t["spam"]):
            write_spam_runs(lab, clock)
        write_pulse_runs(lab, clock)
        if len(t["ramsey"]):
            write_ramsey_runs(lab, clock)
        if len(t["detector_linearity"]):
            write_linearity_runs(lab, clock)
        if len(t["thermometry"]):
            write_thermometry_runs(lab, clock)
        text = _mapping_text(campaign, [n for n in CAMPAIGN_TABLES if len(t[n])], tmp)
        (tmp / "mapping.toml").write_text(text)
    return out / "mapping.toml"


def read_campaign_tables(folder) -> tuple:
    """(tables, campaign.json) of a campaign folder (tables it lacks are left out).

    The folder is first read as ``dpdfit analyze`` reads it
    (:class:`~dpdfit.recordings.campaign_folder.CampaignFolder`: campaign.json, then every
    row of each table present, its values and ranges), so that a damaged table is
    refused naming its file, column and row before anything is simulated; each table is
    then returned as pandas reads it
    (:func:`~dpdfit.simulation.ndscan_lab.read_campaign_table`), as the simulator wrote
    it."""
    folder = Path(folder)
    camp = CampaignFolder(folder)
    present = [t for t in CAMPAIGN_TABLES if os.path.lexists(folder / f"{t}.csv")]
    for t in present:
        getattr(camp, READERS[t])
    camp.recording_times
    tables = {t: read_campaign_table(folder, t) for t in present}
    return tables, campaign_meta(camp)


def _outside(campaign: Path, out: Path) -> None:
    c, o = campaign.resolve(), out.resolve()
    if o == c or c in o.parents:
        raise InputError("is inside the campaign folder: the new recordings are written to a "
                         "folder of their own, never into the campaign", file=str(out))
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise InputError("exists and is not empty (the mapping's globs would pick up its "
                         "old files); choose a new folder", file=str(out))


def record_schedule(campaign_dir, schedule, out_dir, progress=None) -> StandInRecording:
    """Let the simulator stand in for the lab: record a schedule of a simulated campaign.

    Parameters
    ----------
    campaign_dir : path-like
        A simulated campaign (with its ``truth.json``, :meth:`CampaignConfig.from_truth`).
    schedule : path-like or pandas.DataFrame
        The schedule (:func:`~dpdfit.recordings.schedule.read_schedule`), recorded as
        :func:`~dpdfit.simulation.further_recordings.schedule_measurements` reads it.
    out_dir : path-like
        A new folder, not inside ``campaign_dir``: the new recordings only, as ARTIQ
        results files plus ``mapping.toml`` (:func:`write_recorded_results`).
    progress : callable, optional
        As :func:`~dpdfit.simulation.recorded_schedule.record_further` takes it.

    Returns
    -------
    StandInRecording
        The new rows, exactly as the whole extended campaign has them.

    Raises
    ------
    InputError
        One line: no truth.json, a schedule or setting the campaign cannot record (a
        point the simulator does not record as scheduled:
        :func:`~dpdfit.simulation.scheduled_points.check_recorded_as_scheduled`), a
        campaign whose truth.json does not generate its recordings, an output folder
        that exists or lies inside the campaign.  Nothing is written then.
    """
    folder, out = Path(campaign_dir), Path(out_dir)
    truth = folder / "truth.json"
    if not os.path.lexists(truth):
        raise InputError("has no truth.json: only a simulated campaign can stand in for the "
                         "lab", file=str(folder))
    _outside(folder, out)
    df = schedule if isinstance(schedule, pd.DataFrame) else read_schedule(schedule)
    measurements = schedule_measurements(df)
    # a regular file inside the campaign, bounded in size and depth (read_input_json)
    recorded = read_input_json(truth, within=folder, what="truth.json")
    cfg = CampaignConfig.from_truth(recorded, file=str(truth))     # checked before it runs
    tables, campaign = read_campaign_tables(folder)
    rec = record_further(cfg, measurements, original=tables, progress=progress)
    check_recorded_as_scheduled(df, rec.tables, str(schedule) if not isinstance(
        schedule, pd.DataFrame) else "schedule")
    write_recorded_results(rec.tables, tables, campaign, out)
    return rec
