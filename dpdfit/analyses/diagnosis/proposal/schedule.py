"""The proposed recording as a schedule: the points a lab records, one row each.

:func:`proposal_schedule` turns the diagnosis's ``next_measurement`` (``what`` and
``settings``, in the diagnosis's own terms: ``"scans": 92``, parity shots counted over
every phase) into the rows of a schedule file (:mod:`dpdfit.recordings.schedule`),
taking from the campaign what the proposal leaves implicit because the campaign already
fixes it:

* a calibration run records the amplitude grid of the campaign's latest run of its kind;
* a parity scan records the phases the campaign's parity scans of that setting have (the
  analysis phases ``2 pi k / parity_phases`` without one), each with the proposal's shots
  divided by ``parity_phases`` (as the proposal counts them);
* a time scan records the times the campaign's time scan of that setting has;
* spectra record each amplitude with both flags; an amplitude the proposal lists ``k``
  times is recorded in repeats 1..k;
* a SPAM characterisation records each prepared state (``prepared``) with the proposal's
  shots, at ``A`` 0 (no gate), one point per state.

Repeats (``scans``, ``runs``) become the ``repeat`` column; the proposal's lab time is
spread evenly over the rows (``lab_s``).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from dpdfit.core.defaults import ERROR_MODEL
from dpdfit.errors import InputError
from dpdfit.recordings.calibration_runs import list_runs
from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.recordings.schedule import SCHEDULE_COLUMNS, check_schedule

__all__ = ["proposal_schedule"]


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


def _at(df: pd.DataFrame | None, A: float, d: int) -> pd.DataFrame:
    if df is None:
        return pd.DataFrame()
    return df[np.isclose(df["A"].to_numpy(float), A, rtol=0, atol=1e-9)
              & (df["dpd"].to_numpy(float) == d)]


def _runs(what: str, st: dict, camp: CampaignFolder) -> list:
    grid = _latest_grid(camp.amplitude_runs if what == "amplitude_run" else camp.phase_runs)
    if grid is None:
        raise InputError(f"the campaign has no {what.replace('_', ' ')} whose amplitude grid "
                         "a further run could repeat", file=str(camp.folder))
    return [{"repeat": r, "point": i, "A": float(a)}
            for r in range(1, int(st.get("runs", 1)) + 1) for i, a in enumerate(grid)]


def _spectra(st: dict) -> list:
    amps = [float(a) for a in st.get("amplitudes") or ()]
    flags = sorted(int(d) for d in st.get("dpd", (0, 1)))
    seen: dict = {}
    rows = []
    for a in amps:                        # the k-th listing of an amplitude: repeat k
        seen[a] = seen.get(a, 0) + 1
        rows += [{"repeat": seen[a], "A": a, "dpd": d} for d in flags]
    rows.sort(key=lambda r: (r["repeat"], r["A"], r["dpd"]))
    point: dict = {}
    for r in rows:
        r["point"] = point.get(r["repeat"], 0)
        point[r["repeat"]] = r["point"] + 1
    return rows


def _scan_points(what: str, st: dict, camp: CampaignFolder) -> list:
    """``[{point, shots, phase_rad | t_us}]`` of one scan."""
    A, d, shots = float(st["A"]), int(st["dpd"]), int(st["shots"])
    if what == "populations":
        return [{"point": 0, "shots": shots}]
    if what == "parity":
        rec = _at(camp.parity, A, d)
        phases = (np.unique(rec["phase_rad"].to_numpy(float)) if len(rec)
                  else ERROR_MODEL.analysis_phases())
        each = max(1, int(round(shots / ERROR_MODEL.parity_phases)))
        return [{"point": i, "shots": each, "phase_rad": float(p)}
                for i, p in enumerate(phases)]
    rec = _at(camp.time_scans, A, d)
    if not len(rec):
        raise InputError(f"the campaign has no time scan at A = {A:g}, dpd = {d} whose times "
                         "a further one could repeat", file=str(camp.folder))
    times = np.unique(rec["t_us"].to_numpy(float))
    return [{"point": i, "shots": shots, "t_us": float(t)} for i, t in enumerate(times)]


def proposal_schedule(proposal, campaign) -> pd.DataFrame:
    """The proposed recording as a schedule table (module doc).

    Parameters
    ----------
    proposal : dict or NextMeasurement
        The diagnosis's ``next_measurement`` (its ``to_dict()`` or the object).
    campaign : CampaignFolder or path-like
        The campaign the proposal was made for (its grids, phases and times).

    Returns
    -------
    pandas.DataFrame
        The columns of :data:`~dpdfit.recordings.schedule.SCHEDULE_COLUMNS`, one row per
        point and repeat, checked as :func:`~dpdfit.recordings.schedule.read_schedule`
        checks a file.

    Raises
    ------
    InputError
        No recording was proposed (``what`` None: the line gives the reason), or the
        campaign lacks what the recording repeats (a run's grid, a time scan's times).
    """
    p = proposal.to_dict() if hasattr(proposal, "to_dict") else dict(proposal or {})
    what, st = p.get("what"), dict(p.get("settings") or {})
    if what is None:
        raise InputError("no recording was proposed, so there is nothing to schedule: "
                         f"{p.get('reason') or 'the diagnosis is not ambiguous'}")
    camp = campaign if isinstance(campaign, CampaignFolder) else CampaignFolder(campaign)
    if what in ("amplitude_run", "phase_run"):
        rows = _runs(what, st, camp)
    elif what == "spectra":
        rows = _spectra(st)
    elif what == "spam":
        rows = [{"repeat": r, "point": i, "A": 0.0, "shots": int(st["shots"]),
                 "prepared": str(s)}
                for r in range(1, int(st.get("scans", 1)) + 1)
                for i, s in enumerate(st.get("states", ("00", "11")))]
    elif what in ("populations", "parity", "time_scan"):
        one = _scan_points(what, st, camp)
        rows = [{"repeat": r, "A": float(st["A"]), "dpd": int(st["dpd"]), **pt}
                for r in range(1, int(st.get("scans", 1)) + 1) for pt in one]
    else:
        raise InputError(f"unknown recording {what!r} in the proposal")
    df = pd.DataFrame(rows)
    df.insert(0, "kind", what)
    df["lab_s"] = float(p.get("lab_seconds") or 0.0) / max(len(df), 1)
    for col in SCHEDULE_COLUMNS:
        if col not in df.columns:
            df[col] = np.nan
    cols = list(SCHEDULE_COLUMNS) + (["prepared"] if "prepared" in df.columns else [])
    return check_schedule(df[cols], "the proposal's schedule")
