"""The proposed recording as a schedule: the points a lab records, one row each.

:func:`proposal_schedule` turns the diagnosis's ``next_measurement`` (``what`` and
``settings``, in the diagnosis's own terms: ``"scans": 92``, parity shots counted over
every phase) into the rows of a schedule file (:mod:`dpdfit.recordings.schedule`),
taking from the campaign what the proposal leaves implicit because the campaign already
fixes it:

* a calibration run records the amplitude grid of the campaign's latest run of its kind;
* a parity scan records the phases the campaign's parity scans of that setting have
  (without one, the analysis phases ``2 pi k / n`` with ``n`` the campaign's
  ``parity_phases``), each with the proposal's shots divided by the number of phases
  written (rounded), so that shots per phase times phases is the proposal's shots;
* a time scan records the times after the start (``t > 0``) the campaign's time scan of
  that setting has: the points the diagnosis fits and the proposal counts
  (``points``); the start ``t = 0`` carries nothing the diagnosis uses;
* spectra record each amplitude with both flags, one row per trace; an amplitude the
  proposal lists ``k`` times is recorded in repeats 1..k, each trace with the tone
  repeatability the proposal assumed (``tone_sd_db``);
* a SPAM characterisation records each prepared state (``prepared``) with the proposal's
  shots, at ``A`` 0 (no gate), one point per state;
* an AOM pulse response records one trace of a step to ``A`` per repeat (one point);
* a Ramsey and spin-echo scan records each sequence (``sequence``) at each wait
  (``wait_us``) of the scan the menu counted (the campaign's stated T2 sets it), with the
  proposal's shots per point, at ``A`` 0 (no gate);
* a detector linearity characterisation records each of its drives
  (:func:`~dpdfit.recordings.detector_linearity.linearity_drives`) once without and once
  with the attenuator (``attenuation_db``), one point per drive; its ``lab_s`` is the
  two readings (``2 linearity_reading_s``) and the drive's share of putting the
  attenuator in (``attenuator_swap_s``);
* a sideband thermometry records each wait (``wait_us``) on each sideband (``sideband``)
  with the proposal's shots, at ``A`` 0, one point each (:func:`thermometry_rows`).

Repeats (``scans``, ``runs``) become the ``repeat`` column.  What each row costs and
when it is taken:

* ``lab_s``: the row's own lab time by :class:`~dpdfit.core.defaults.LabTimes`, as the
  menu counts it (:mod:`~dpdfit.analyses.diagnosis.proposal.menu`): ``shots * shot_s``
  for a scan point (``shots * spam_shot_s`` for a SPAM state, ``shots * (ramsey_shot_s +
  wait) + ramsey_point_s`` for a Ramsey point, ``shots * (thermometry_shot_s + wait)``
  for a thermometry point), ``spectrum_trace_s`` for a trace (``pulse_trace_s`` for a
  pulse response), the run's time over its grid points for a calibration-run point;
  rescaled so that the column sums to the
  proposal's ``lab_seconds`` (a proposal made with the same lab times needs no rescaling).
* Calibration runs are paced, not taken back to back: the proposal counts each further
  run as an independent draw of the campaign's run-to-run scatter (the drift modes' sd,
  learnt from runs taken hours or days apart), which runs taken back to back are not.
  So they are spread as the campaign's own runs of that kind were: run ``r`` starts
  ``(r - 1)`` intervals after the first, the interval the median gap between the starts
  of the campaign's consecutive runs (whole days when it is a day or more; at least the
  run's own lab time; a day when the runs carry no timestamps, :func:`run_interval`).
  Within a run the points follow each other back to back.
* Every other recording is taken back to back in the order of its rows, in the next
  session (``day`` 0).

``day`` counts whole days from that next session, which the proposal predicts as if it
were the day of the campaign's latest recording ("now": a drifting calibration is
predicted at that day); ``start_s`` is the row's start in seconds from the start of its
day's session (a day's session starts at the hour day 0's did).  The waits between paced
runs are not lab time and are not in ``lab_s``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from dpdfit.core.defaults import ERROR_MODEL, LAB_TIMES, LINEARITY_ATTENUATION_DB
from dpdfit.errors import InputError
from dpdfit.models.ramsey import SCAN_POINTS, SEQUENCES, scan_waits
from dpdfit.models.sideband_thermometry import SIDEBANDS, THERMOMETRY_WAITS_US
from dpdfit.recordings.calibration_runs import list_runs
from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.recordings.detector_linearity import linearity_drives
from dpdfit.recordings.schedule import (LINEARITY_COLUMN, RUN_KINDS, SCHEDULE_COLUMNS,
                                        check_schedule)

__all__ = ["proposal_schedule", "run_interval", "DAY_S", "thermometry_rows"]

#: seconds of a day: the unit of the schedule's ``day`` column
DAY_S = 86400.0


def _latest_grid(runs: pd.DataFrame | None) -> np.ndarray | None:
    """The amplitudes of the latest run of a calibration table (by timestamp, else the
    last in the file), None without one."""
    if runs is None or len(runs) == 0:
        return None
    labels = list_runs(runs)
    if not labels:
        return runs["A"].to_numpy(float)
    if "timestamp" in runs.columns:
        last = runs.groupby("run", sort=False)["timestamp"].min().idxmax()
    else:
        last = labels[-1]
    return runs.loc[runs["run"] == last, "A"].to_numpy(float)


def run_interval(runs: pd.DataFrame | None, run_s: float) -> float:
    """Seconds between the starts of consecutive further calibration runs: the median gap
    between the starts of the campaign's consecutive runs ``runs`` (one calibration
    table), in whole days when it is a day or more, at least ``run_s`` (a run's own lab
    time); a day when the runs carry no timestamps or fewer than two runs have one."""
    gap = DAY_S
    if runs is not None and len(runs) and "timestamp" in runs.columns \
            and "run" in runs.columns:
        starts = pd.to_datetime(runs.groupby("run", sort=False)["timestamp"].min(),
                                utc=True).dropna().sort_values()
        gaps = np.diff(starts.to_numpy()).astype("timedelta64[ns]").astype(float) / 1e9
        gaps = gaps[gaps > 0]
        if gaps.size:
            gap = float(np.median(gaps))
    if gap >= DAY_S:
        gap = float(np.round(gap / DAY_S)) * DAY_S
    return max(gap, float(run_s))


def _at(df: pd.DataFrame | None, A: float, d: int) -> pd.DataFrame:
    if df is None:
        return pd.DataFrame()
    return df[np.isclose(df["A"].to_numpy(float), A, rtol=0, atol=1e-9)
              & (df["dpd"].to_numpy(float) == d)]


def _run_table(what: str, camp: CampaignFolder) -> pd.DataFrame | None:
    return camp.amplitude_runs if what == "amplitude_run" else camp.phase_runs


def _runs(what: str, st: dict, camp: CampaignFolder) -> list:
    grid = _latest_grid(_run_table(what, camp))
    if grid is None:
        table = "calibration_amplitude.csv" if what == "amplitude_run" else \
            "calibration_phase.csv"
        raise InputError(f"the campaign has no {what.replace('_', ' ')} whose amplitude grid "
                         "a further run could repeat", file=str(camp.file(table)))
    return [{"repeat": r, "point": i, "A": float(a)}
            for r in range(1, int(st.get("runs", 1)) + 1) for i, a in enumerate(grid)]


def _spectra(st: dict) -> list:
    amps = [float(a) for a in st.get("amplitudes") or ()]
    flags = sorted(int(d) for d in st.get("dpd", (0, 1)))
    sd = st.get("tone_sd_db")
    sd = np.nan if sd is None else float(sd)
    seen: dict = {}
    rows = []
    for a in amps:                        # the k-th listing of an amplitude: repeat k
        seen[a] = seen.get(a, 0) + 1
        rows += [{"repeat": seen[a], "A": a, "dpd": d, "tone_sd_db": sd} for d in flags]
    rows.sort(key=lambda r: (r["repeat"], r["A"], r["dpd"]))
    point: dict = {}
    for r in rows:
        r["point"] = point.get(r["repeat"], 0)
        point[r["repeat"]] = r["point"] + 1
    return rows


def _linearity_rows(st: dict) -> list:
    """One row per drive of each repeat of a detector linearity characterisation."""
    att = float(st.get("attenuation_db", LINEARITY_ATTENUATION_DB))
    return [{"repeat": r, "point": i, "A": float(a), "attenuation_db": att}
            for r in range(1, int(st.get("scans", 1)) + 1)
            for i, a in enumerate(linearity_drives(int(st["points"])))]


def _parity_phases(camp: CampaignFolder) -> int:
    """The campaign's ``parity_phases`` (``campaign.json``; the lab's default without it)."""
    n = camp.meta.get("parity_phases", ERROR_MODEL.parity_phases)
    if isinstance(n, bool) or not isinstance(n, (int, float)) or not np.isfinite(n) \
            or n != int(n) or n < 1:
        raise InputError(f"parity_phases {n!r} must be an integer >= 1",
                         file=str(camp.file("campaign.json")))
    return int(n)


def _scan_points(what: str, st: dict, camp: CampaignFolder) -> list:
    """``[{point, shots, phase_rad | t_us}]`` of one scan."""
    A, d, shots = float(st["A"]), int(st["dpd"]), int(st["shots"])
    if what == "populations":
        return [{"point": 0, "shots": shots}]
    if what == "parity":
        rec = _at(camp.parity, A, d)
        if len(rec):
            phases = np.unique(rec["phase_rad"].to_numpy(float))
        else:
            n = _parity_phases(camp)
            phases = np.arange(n) * 2 * np.pi / n
        each = max(1, int(round(shots / phases.size)))
        return [{"point": i, "shots": each, "phase_rad": float(p)}
                for i, p in enumerate(phases)]
    rec = _at(camp.time_scans, A, d)
    times = np.unique(rec["t_us"].to_numpy(float)) if len(rec) else np.array([])
    times = times[times > 0]
    if not times.size:
        raise InputError(f"the campaign has no time scan at A = {A:g}, dpd = {d} whose times "
                         "a further one could repeat", file=str(camp.file("time_scans.csv")))
    if "points" in st and int(st["points"]) != times.size:
        raise InputError(f"the proposal's time scan at A = {A:g}, dpd = {d} has "
                         f"{int(st['points'])} points, the campaign's has {times.size} "
                         "times after the start: the proposal was not made for this campaign",
                         file=str(camp.file("time_scans.csv")))
    return [{"point": i, "shots": shots, "t_us": float(t)} for i, t in enumerate(times)]


def _ramsey_points(st: dict, camp: CampaignFolder) -> list:
    """The rows of a Ramsey and spin-echo scan: each sequence at the waits of
    :func:`~dpdfit.models.ramsey.scan_waits` for the campaign's stated T2 (its
    ``error_model`` ``T2_s``, else the lab's default), as the menu counted them."""
    em = camp.raw_meta.get("error_model")
    T2 = float(em["T2_s"]) if isinstance(em, dict) and "T2_s" in em else ERROR_MODEL.T2_s
    waits = scan_waits(T2, int(st.get("points", SCAN_POINTS)))
    return [{"repeat": r, "point": j * waits.size + i, "A": 0.0, "shots": int(st["shots"]),
             "sequence": seq, "wait_us": round(float(w) * 1e6, 3)}
            for r in range(1, int(st.get("scans", 1)) + 1)
            for j, seq in enumerate(SEQUENCES) for i, w in enumerate(waits)]


def _row_seconds(df: pd.DataFrame, what: str, lab) -> np.ndarray:
    """Each row's own lab time by the lab times ``lab`` (module doc)."""
    if what in RUN_KINDS:
        run_s = lab.amplitude_run_s if what == "amplitude_run" else lab.phase_run_s
        return run_s / df.groupby("repeat")["point"].transform("size").to_numpy(float)
    if what == "spectra":
        return np.full(len(df), float(lab.spectrum_trace_s))
    if what == "spam":
        return df["shots"].to_numpy(float) * lab.spam_shot_s
    if what == "pulse_response":
        return np.full(len(df), float(lab.pulse_trace_s))
    if what == "ramsey":
        return (df["shots"].to_numpy(float) * (lab.ramsey_shot_s
                                               + df["wait_us"].to_numpy(float) * 1e-6)
                + lab.ramsey_point_s)
    if what == "detector_linearity":
        per = df.groupby("repeat")["point"].transform("size").to_numpy(float)
        return 2 * lab.linearity_reading_s + lab.attenuator_swap_s / per
    if what == "thermometry":                    # each shot also waits its wait
        return df["shots"].to_numpy(float) * (lab.thermometry_shot_s
                                              + df["wait_us"].to_numpy(float) * 1e-6)
    return df["shots"].to_numpy(float) * lab.shot_s


def _lab_seconds(df: pd.DataFrame, what: str, total, lab) -> np.ndarray:
    """``lab_s``: the rows' own lab times, rescaled to sum to the proposal's ``total``
    (kept as they are without one)."""
    w = _row_seconds(df, what, lab)
    if total is None:
        return w
    total, s = float(total), float(w.sum())
    return w * (total / s) if s > 0 else np.full(len(df), total / max(len(df), 1))


def _timing(df: pd.DataFrame, what: str, camp: CampaignFolder) -> tuple:
    """``(day, start_s)`` of each row (module doc): calibration runs paced by
    :func:`run_interval`, every other recording back to back from the session's start."""
    lab_s = df["lab_s"].to_numpy(float)
    if what in RUN_KINDS:
        within = df.groupby("repeat")["lab_s"].cumsum().to_numpy(float) - lab_s
        run_s = float(df.groupby("repeat")["lab_s"].sum().max())
        gap = run_interval(_run_table(what, camp), run_s)
        offset = (df["repeat"].to_numpy(float) - 1) * gap + within
    else:
        offset = np.cumsum(lab_s) - lab_s
    day = np.floor(offset / DAY_S)
    return day.astype(int), offset - day * DAY_S


def proposal_schedule(proposal, campaign, lab=None) -> pd.DataFrame:
    """The proposed recording as a schedule table (module doc).

    Parameters
    ----------
    proposal : dict or NextMeasurement
        The diagnosis's ``next_measurement`` (its ``to_dict()`` or the object).
    campaign : CampaignFolder or path-like
        The campaign the proposal was made for (its grids, phases, times and the
        spacing of its calibration runs).
    lab : dpdfit.core.defaults.LabTimes, optional
        The lab times the proposal was made with (default
        :data:`~dpdfit.core.defaults.LAB_TIMES`): each row's share of ``lab_seconds``.

    Returns
    -------
    pandas.DataFrame
        The columns of :data:`~dpdfit.recordings.schedule.SCHEDULE_COLUMNS`, one row per
        point and repeat, checked as :func:`~dpdfit.recordings.schedule.read_schedule`
        checks a file.

    Raises
    ------
    InputError
        No recording was proposed (``what`` None: the line gives the reason), the
        campaign lacks what the recording repeats (a run's grid, a time scan's times),
        or a time scan's ``points`` differ from the campaign's times after the start.
    """
    p = proposal.to_dict() if hasattr(proposal, "to_dict") else dict(proposal or {})
    what, st = p.get("what"), dict(p.get("settings") or {})
    if what is None:
        raise InputError("no recording was proposed, so there is nothing to schedule: "
                         f"{p.get('reason') or 'the diagnosis is not ambiguous'}")
    camp = campaign if isinstance(campaign, CampaignFolder) else CampaignFolder(campaign)
    if what in RUN_KINDS:
        rows = _runs(what, st, camp)
    elif what == "spectra":
        rows = _spectra(st)
    elif what == "spam":
        rows = [{"repeat": r, "point": i, "A": 0.0, "shots": int(st["shots"]),
                 "prepared": str(s)}
                for r in range(1, int(st.get("scans", 1)) + 1)
                for i, s in enumerate(st.get("states", ("00", "11")))]
    elif what == "pulse_response":
        rows = [{"repeat": r, "point": 0, "A": float(st["A"])}
                for r in range(1, int(st.get("scans", 1)) + 1)]
    elif what == "ramsey":
        rows = _ramsey_points(st, camp)
    elif what == "detector_linearity":
        rows = _linearity_rows(st)
    elif what == "thermometry":
        rows = thermometry_rows(st)
    elif what in ("populations", "parity", "time_scan"):
        one = _scan_points(what, st, camp)
        rows = [{"repeat": r, "A": float(st["A"]), "dpd": int(st["dpd"]), **pt}
                for r in range(1, int(st.get("scans", 1)) + 1) for pt in one]
    else:
        raise InputError(f"unknown recording {what!r} in the proposal")
    df = pd.DataFrame(rows)
    df.insert(0, "kind", what)
    for col in SCHEDULE_COLUMNS:
        if col not in df.columns:
            df[col] = np.nan
    df["lab_s"] = _lab_seconds(df, what, p.get("lab_seconds"),
                               LAB_TIMES if lab is None else lab)
    df["day"], df["start_s"] = _timing(df, what, camp)
    cols = list(SCHEDULE_COLUMNS) + [c for c in ("prepared", "sequence", "wait_us",
                                                 LINEARITY_COLUMN, "sideband")
                                     if c in df.columns]
    return check_schedule(df[cols], "the proposal's schedule")


def thermometry_rows(st: dict) -> list:
    """The schedule rows of a proposed sideband thermometry ``st`` (``shots``,
    ``waits_us``, ``sidebands``, ``scans``): each wait probed on each sideband, one point
    each, at ``A`` 0 (no gate)."""
    waits = st.get("waits_us") or THERMOMETRY_WAITS_US
    sidebands = st.get("sidebands") or SIDEBANDS
    return [{"repeat": r, "point": i, "A": 0.0, "shots": int(st["shots"]),
             "wait_us": float(w), "sideband": str(s)}
            for r in range(1, int(st.get("scans", 1)) + 1)
            for i, (w, s) in enumerate((w, s) for w in waits for s in sidebands)]
