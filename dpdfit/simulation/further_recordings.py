"""A further recording added to a campaign's config, and the menu it is drawn from.

What the diagnosis proposes (``next_measurement``: ``what`` and ``settings``) becomes
one more entry of the simulator's config (:func:`extend_config`), drawn from random
streams of its own, so that every recording the campaign already had is drawn exactly
as before; :func:`default_menu` and :func:`random_menu_choice` give the recording a
blind choice would take instead (the closed loop's comparison,
:mod:`dpdfit.simulation.closed_loop`).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from dpdfit.core.defaults import ERROR_MODEL, LINEARITY_POINTS
from dpdfit.errors import InputError
from dpdfit.recordings.schedule import check_schedule
from dpdfit.simulation.campaign import CampaignConfig

__all__ = ["MEASUREMENTS", "NOMINAL_SHOTS", "extend_config", "default_menu",
           "random_menu_choice", "schedule_measurements"]

#: What a measurement can be (``what``) -> its kind; the random choice is uniform over
#: the kinds (a population scan and a parity scan are both one scan at a gate setting).
#: ``spam``, ``pulse_response``, ``ramsey``, ``detector_linearity`` and ``thermometry``
#: are drawn when the proposal's menu offers them; :func:`default_menu` (the menu of a
#: proposal without one) leaves them out, so that a blind choice without a menu is drawn
#: as before.
MEASUREMENTS = {"amplitude_run": "amplitude_run", "phase_run": "phase_run",
                "spectra": "spectra", "populations": "scan", "parity": "scan",
                "time_scan": "time_scan", "spam": "spam", "pulse_response": "pulse_response",
                "ramsey": "ramsey", "detector_linearity": "detector_linearity",
                "thermometry": "thermometry"}
#: Shots per point of a scan of the default menu (the campaign's nominal shots).
NOMINAL_SHOTS = 625


def _positive_int(v, name: str, least: int = 1) -> int:
    try:
        ok = int(v) == v and int(v) >= least
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise InputError(f"measurement setting {name} = {v!r}: must be an integer >= {least}")
    return int(v)


def _amplitude(v, known=()) -> float:
    """An amplitude in (0, 1]; one of ``known`` (within 1e-9) is taken as that one,
    so that the simulator finds the setting it already has."""
    try:
        a = float(v)
    except (TypeError, ValueError):
        a = float("nan")
    if not 0 < a <= 1:
        raise InputError(f"measurement amplitude {v!r}: must be in (0, 1]")
    return next((float(k) for k in known if abs(float(k) - a) < 1e-9), a)


def _setting(cfg: CampaignConfig, st: dict) -> tuple:
    A = _amplitude(st.get("A"), cfg.gate_amplitudes)
    d = st.get("dpd")
    if d not in (0, 1):
        raise InputError(f"measurement setting dpd = {d!r}: must be 0 or 1")
    return A, int(d), _positive_int(st.get("shots", NOMINAL_SHOTS), "shots")


def _characterisation(cfg: CampaignConfig, what: str, st: dict, scans: int) -> CampaignConfig:
    """``cfg`` with ``scans`` further characterisation items of kind ``what`` (SPAM: its
    shots per prepared state; the pulse response: its step's amplitude; the Ramsey scan:
    its shots per point; the detector linearity: its drives, at least 2, default
    :data:`~dpdfit.core.defaults.LINEARITY_POINTS`; the sideband thermometry: its shots
    per wait and sideband)."""
    if what in ("spam", "ramsey", "thermometry"):
        item = (what, _positive_int(st.get("shots", NOMINAL_SHOTS), "shots"))
    elif what == "detector_linearity":
        item = (what, _positive_int(st.get("points", LINEARITY_POINTS), "points", least=2))
    else:
        item = ("pulse_response", _amplitude(st.get("A", cfg.time_scan_A)))
    return dataclasses.replace(cfg, further=cfg.further + (item,) * scans)


def extend_config(cfg: CampaignConfig, measurement: dict) -> CampaignConfig:
    """The campaign config with one further recording: the measurement ``measurement``.

    Parameters
    ----------
    cfg : CampaignConfig
        The campaign's config (e.g. the harness's, with the effects injected).
    measurement : dict
        ``{"what", "settings"}`` as the diagnosis proposes it: ``amplitude_run`` /
        ``phase_run`` (``{"runs": n}``, default 1), ``spectra`` (``{"amplitudes":
        [...], "dpd": [0, 1]}``), ``populations`` / ``parity`` (``{"A", "dpd",
        "shots"}``: parity shots are the scan's total over its phases, as the
        proposal counts them), ``time_scan`` (``{"A", "dpd", "shots", "points"}``:
        shots per point, points after the start; the scan also records ``t = 0``),
        ``spam`` (``{"shots"}``: shots per prepared state, ``|00>`` and ``|11>``),
        ``pulse_response`` (``{"A"}``: a trace of a step to ``A``, else time_scan_A),
        ``ramsey`` (``{"shots"}``: per point, waits :func:`~dpdfit.models.ramsey.scan_waits`),
        ``detector_linearity`` (``{"points"}``: drives, at least 2), ``thermometry``
        (``{"shots"}``: shots per wait and sideband).

    Returns
    -------
    CampaignConfig
        ``cfg`` with the recording added (:attr:`CampaignConfig.further`, or trace
        amplitudes appended); every recording of ``cfg`` is drawn exactly as before.
        Amplitude runs are taken an hour or two after the last run, phase runs
        one step of the phase-run schedule after the last; spectra with both
        flags (at a recorded amplitude: recorded again at exactly that amplitude, as
        repeated rows of ``spectra.csv``); a population (parity)
        scan at a gate setting adds population (parity) rows only, at a new
        amplitude a setting with its gate-rate calibration and both (the
        diagnosis analyses a setting only with both).

    Raises
    ------
    InputError
        An unknown ``what``, no measurement (``what`` None), settings out of
        range, or spectra of one flag only or of no amplitude.
    """
    what = (measurement or {}).get("what")
    st = (measurement or {}).get("settings") or {}
    if what in ("amplitude_run", "phase_run"):
        runs = _positive_int(st.get("runs", 1), "runs")
        return dataclasses.replace(cfg, further=cfg.further + ((what,),) * runs)
    if what == "spectra":
        if sorted(set(st.get("dpd", (0, 1)))) != [0, 1]:
            raise InputError("spectra are recorded with both dpd flags (dpd [0, 1]), got "
                             f"{st.get('dpd')!r}")
        # an amplitude already recorded is recorded again at exactly that amplitude
        have = tuple(cfg.trace_amplitudes)
        new = [_amplitude(a, have) for a in st.get("amplitudes") or ()]
        if not new:
            raise InputError("spectra: no amplitudes given")
        return dataclasses.replace(cfg, trace_amplitudes=tuple(cfg.trace_amplitudes)
                                   + tuple(new))
    scans = _positive_int(st.get("scans", 1), "scans")
    if what in ("populations", "parity", "time_scan") and scans > 1:
        # repeated scans, each with its own random power error: one after the other
        one = {**measurement, "settings": {**st, "scans": 1}}
        for _ in range(scans):
            cfg = extend_config(cfg, one)
        return cfg
    if what in ("populations", "parity"):
        A, d, shots = _setting(cfg, st)
        if what == "parity":
            shots = max(1, round(shots / ERROR_MODEL.parity_phases))    # per phase
        new_setting = A not in cfg.gate_amplitudes
        item = ("scan", A, d, shots if what == "populations" or new_setting else 0,
                shots if what == "parity" or new_setting else 0)
        return dataclasses.replace(cfg, further=cfg.further + (item,))
    if what == "time_scan":
        A, d, shots = _setting(cfg, st)
        points = _positive_int(st.get("points", cfg.time_scan_points - 1), "points")
        return dataclasses.replace(cfg, further=cfg.further + (("time_scan", A, d, shots,
                                                                 points + 1),))
    if what in ("spam", "pulse_response", "ramsey", "detector_linearity", "thermometry"):
        return _characterisation(cfg, what, st, scans)
    if what is None:
        raise InputError("no measurement was proposed (what is None): nothing to add")
    raise InputError(f"unknown measurement '{what}'; known: {', '.join(MEASUREMENTS)}")


def schedule_measurements(schedule) -> list:
    """The measurements (``{"what", "settings"}``, as :func:`extend_config` takes them) a
    schedule lists, in the order of its rows' first appearance.

    Parameters
    ----------
    schedule : pandas.DataFrame
        A schedule (:func:`~dpdfit.recordings.schedule.read_schedule`): its repeats of a
        kind at one setting become ``runs`` / ``scans``; spectra list every trace
        amplitude of every repeat (both flags needed); a parity scan's shots are counted
        over its phases, as the proposal counts them; a time scan's ``points`` are its
        times after the start (``t_us > 0``); the pacing columns (``day``,
        ``start_s``) are not read: the simulator takes further runs an hour or two apart.

    Returns
    -------
    list of dict
        One measurement per kind and setting.  The simulator records calibration runs on
        its own amplitude grid and a time scan on its own times (as many as scheduled):
        those the schedule took from the campaign.
    """
    df = check_schedule(schedule)
    out = []
    for kind in dict.fromkeys(df["kind"]):
        rows = df[df["kind"] == kind]
        if kind in ("amplitude_run", "phase_run"):
            out.append({"what": kind, "settings": {"runs": int(rows["repeat"].nunique())}})
            continue
        if kind == "pulse_response":
            for A, reps in rows.groupby("A", sort=False):
                st = {"A": float(A), "scans": int(reps["repeat"].nunique())}
                out.append({"what": kind, "settings": st})
            continue
        if kind == "detector_linearity":
            out += _linearity_measurements(rows)
            continue
        if kind in ("spam", "ramsey", "thermometry"):    # the simulator's own states / waits
            for shots, reps in rows.groupby("shots", sort=False):
                st = {"shots": int(shots), "scans": int(reps["repeat"].nunique())}
                out.append({"what": kind, "settings": st})
            continue
        if kind == "spectra":
            amps = rows.drop_duplicates(["repeat", "A"])["A"].tolist()
            flags = sorted({int(d) for d in rows["dpd"]})
            st = {"amplitudes": sorted(amps), "dpd": flags}
            sd = rows["tone_sd_db"].dropna()
            if len(sd):
                st["tone_sd_db"] = float(sd.iloc[0])
            out.append({"what": kind, "settings": st})
            continue
        first = rows.groupby("repeat", sort=False).first()
        per = rows.groupby("repeat", sort=False).size()
        # a time scan's points are its times after the start (an older schedule also
        # listed t = 0, which the simulator records anyway)
        after = (rows["t_us"] > 0).groupby(rows["repeat"], sort=False).sum()
        keys = pd.DataFrame({"A": first["A"], "dpd": first["dpd"], "shots": first["shots"],
                             "n": per, "after": after})
        for (A, d, shots, n, m), reps in keys.groupby(["A", "dpd", "shots", "n", "after"],
                                                      sort=False):
            st = {"A": float(A), "dpd": int(d), "shots": int(shots) * (int(n) if kind ==
                                                                        "parity" else 1),
                  "scans": int(len(reps))}
            if kind == "time_scan":
                st["points"] = int(m)
            out.append({"what": kind, "settings": st})
    return out


def _linearity_measurements(rows: pd.DataFrame) -> list:
    """A schedule's ``detector_linearity`` rows as measurements: repeats of one number of
    drives become ``scans`` (the simulator records its own drives, as many, with its own
    attenuator: those the schedule took from the proposal)."""
    per = rows.groupby("repeat", sort=False).size()
    return [{"what": "detector_linearity", "settings": {"points": int(n),
                                                        "scans": int(len(reps))}}
            for n, reps in per.groupby(per, sort=False)]


def default_menu(rng: np.random.Generator, cfg: CampaignConfig) -> list:
    """One measurement of every ``what`` with settings valid for ``cfg``.

    Parameters
    ----------
    rng : numpy.random.Generator
        Draws the settings: a gate setting ``(A, dpd)`` for the scans, four
        spectra amplitudes half-way between recorded ones.
    cfg : CampaignConfig
        The campaign's config (its gate amplitudes, trace amplitudes, time-scan points).

    Returns
    -------
    list of dict
        ``{"what", "settings"}`` for each of :data:`MEASUREMENTS` but the characterisations
        ``spam``, ``pulse_response``, ``ramsey``, ``detector_linearity`` and
        ``thermometry`` (only a menu that offers them draws them: the default menu's
        kinds, and so its draws, are those it had before them).
    """
    grid = np.sort(np.asarray(cfg.trace_amplitudes, dtype=float))
    mids = np.round(0.5 * (grid[1:] + grid[:-1]), 4)
    amps = sorted(float(a) for a in rng.choice(mids, size=min(4, mids.size), replace=False))

    def setting(shots=NOMINAL_SHOTS):
        return {"A": float(rng.choice(np.asarray(cfg.gate_amplitudes, dtype=float))),
                "dpd": int(rng.integers(2)), "shots": shots}

    return [{"what": "amplitude_run", "settings": {"runs": 1}},
            {"what": "phase_run", "settings": {"runs": 1}},
            {"what": "spectra", "settings": {"amplitudes": amps, "dpd": [0, 1]}},
            {"what": "populations", "settings": setting()},
            {"what": "parity", "settings": setting(NOMINAL_SHOTS * ERROR_MODEL.parity_phases)},
            {"what": "time_scan", "settings": {**setting(), "points": cfg.time_scan_points - 1}}]


def random_menu_choice(rng: np.random.Generator, measurement: dict | None,
                       cfg: CampaignConfig) -> dict:
    """A measurement chosen at random from the menu, uniformly over its kinds.

    Parameters
    ----------
    rng : numpy.random.Generator
        The random stream of the choice.
    measurement : dict or None
        The proposed measurement; its ``menu`` (measurements, or their ``what``
        names) is chosen from when it has one, else :func:`default_menu`.  A menu
        entry without settings gets the default menu's.
    cfg : CampaignConfig
        The campaign's config (for default settings).

    Returns
    -------
    dict
        ``{"what", "settings"}`` (and the menu entry's ``lab_seconds`` when it has one,
        so that the random arm's lab time is counted as the proposal's is): a kind of
        :data:`MEASUREMENTS` drawn uniformly among those on the menu, then one of its
        entries uniformly (the proposed measurement itself may be drawn: the choice is
        blind).
    """
    defaults = default_menu(rng, cfg)
    menu = []
    for m in (measurement or {}).get("menu") or ():
        m = {"what": m} if isinstance(m, str) else m
        if isinstance(m, dict) and m.get("what") in MEASUREMENTS:
            st = m.get("settings") or next((x["settings"] for x in defaults
                                            if x["what"] == m["what"]),
                                           {"shots": NOMINAL_SHOTS})      # spam
            entry = {"what": m["what"], "settings": dict(st)}
            if m.get("lab_seconds") is not None:      # the menu's own lab time, kept
                entry["lab_seconds"] = m["lab_seconds"]
            menu.append(entry)
    menu = menu or defaults
    kinds = sorted({MEASUREMENTS[m["what"]] for m in menu})
    kind = kinds[int(rng.integers(len(kinds)))]
    items = [m for m in menu if MEASUREMENTS[m["what"]] == kind]
    return items[int(rng.integers(len(items)))]
