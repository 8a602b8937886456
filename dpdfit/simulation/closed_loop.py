"""The closed loop of the harness: take the measurement the diagnosis asks for, diagnose again.

When the diagnosis cannot decide between catalog effects it lists the
``alternatives`` and proposes a ``next_measurement`` (one further recording,
chosen from a ``menu``).  :func:`close_loop` simulates that recording under the
campaign's truth, adds it to the campaign and diagnoses again -- and does the
same for a recording chosen at random from the menu (:func:`random_menu_choice`),
the comparison that says whether the proposal is better than chance.

A further recording is a campaign config with one more entry
(:func:`extend_config`), drawn from random streams of its own: every recording
the campaign already had is drawn exactly as before, so the re-diagnosed
campaign is the first one plus the new rows.  :func:`loop_summary` is the
harness summary's part on ambiguity and on the closed loop.
"""

from __future__ import annotations

import dataclasses
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from dpdfit.core.defaults import ERROR_MODEL
from dpdfit.errors import InputError
from dpdfit.simulation.campaign import CampaignConfig, simulate_campaign
from dpdfit.analyses.diagnosis.refits import achieved_separation
from dpdfit.simulation.harness_external import truth_in_reach

__all__ = ["MEASUREMENTS", "NOMINAL_SHOTS", "LOOP_STEPS", "extend_config", "default_menu",
           "random_menu_choice", "close_loop", "ambiguity", "loop_summary",
           "loop_report_lines"]

#: What a measurement can be (``what``) -> its kind; the random choice is uniform over
#: the kinds (a population scan and a parity scan are both one scan at a gate setting).
MEASUREMENTS = {"amplitude_run": "amplitude_run", "phase_run": "phase_run",
                "spectra": "spectra", "populations": "scan", "parity": "scan",
                "time_scan": "time_scan"}
#: Shots per point of a scan of the default menu (the campaign's nominal shots).
NOMINAL_SHOTS = 625
#: Random stream of the random choice: ``SeedSequence([job seed, this])``.
_RANDOM_KEY = 8_101


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
        shots per point, points after the start; the scan also records ``t = 0``).

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
    if what is None:
        raise InputError("no measurement was proposed (what is None): nothing to add")
    raise InputError(f"unknown measurement '{what}'; known: {', '.join(MEASUREMENTS)}")


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
        ``{"what", "settings"}`` for each of :data:`MEASUREMENTS`.
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
        ``{"what", "settings"}``: a kind of :data:`MEASUREMENTS` drawn uniformly
        among those on the menu, then one of its entries uniformly (the
        proposed measurement itself may be drawn: the choice is blind).
    """
    defaults = default_menu(rng, cfg)
    menu = []
    for m in (measurement or {}).get("menu") or ():
        m = {"what": m} if isinstance(m, str) else m
        if isinstance(m, dict) and m.get("what") in MEASUREMENTS:
            st = m.get("settings") or next(x["settings"] for x in defaults
                                           if x["what"] == m["what"])
            menu.append({"what": m["what"], "settings": dict(st)})
    menu = menu or defaults
    kinds = sorted({MEASUREMENTS[m["what"]] for m in menu})
    kind = kinds[int(rng.integers(len(kinds)))]
    items = [m for m in menu if MEASUREMENTS[m["what"]] == kind]
    return items[int(rng.integers(len(items)))]


def ambiguity(d) -> dict:
    """The ambiguity of a diagnosis as the harness records it.

    Parameters
    ----------
    d : Diagnosis or dict
        A diagnosis, its :meth:`~dpdfit.analyses.diagnosis.result.Diagnosis.to_dict`,
        or a harness run record.

    Returns
    -------
    dict
        ``alternatives`` (the diagnosis's list, ``[]`` without one), ``ambiguous``
        (it has alternatives) and ``next_measurement`` (the proposal or None).
    """
    alts = list(_extra(d).get("alternatives") or [])
    return {"alternatives": alts, "ambiguous": bool(alts),
            "next_measurement": _extra(d).get("next_measurement")}


def _extra(d) -> dict:
    if isinstance(d, dict):                 # to_dict() and run records carry extra at the top
        return {**(d.get("extra") or {}), **d}
    return dict(getattr(d, "extra", None) or {})


def _diagnose(folder, refit=None, forms_left_out=None):
    # imported when needed, as run_one does: the diagnosis is heavy to import; a job's
    # left-out forms stay left out of the diagnosis after the further recording
    from dpdfit.analyses.diagnosis.diagnose import diagnose
    kw = {k: v for k, v in (("refit", refit), ("forms_left_out", forms_left_out)) if v}
    return diagnose(folder, progress=False, **kw)


def _status(d, concealed: list) -> str:
    """``"exact"`` (the concealed set named; ``none`` for a null), ``"in_reach"`` (among
    the alternatives) or ``"wrong"`` (confidently wrong)."""
    named = sorted(getattr(d, "named", None) if not isinstance(d, dict)
                   else d.get("named") or [])
    verdict = d.get("verdict") if isinstance(d, dict) else getattr(d, "verdict", None)
    if (named == concealed) if concealed else verdict == "none":
        return "exact"
    rec = {"verdict": verdict, "named": named, "alternatives": ambiguity(d)["alternatives"]}
    return "in_reach" if truth_in_reach(rec, concealed) else "wrong"


def _binding_refits(proposal: dict | None) -> list | None:
    """The binding pair of a proposal (the hypotheses whose separation it predicts), as
    the refits a later diagnosis makes."""
    b = (proposal or {}).get("binding") or {}
    if not b.get("truth") or not b.get("rival"):
        return None
    return [{k: b[r][k] for k in ("effects", "forms")} for r in ("truth", "rival")]


def _step(job: dict, cfg: CampaignConfig, m: dict, before, workdir) -> tuple:
    """One recording: the campaign config with ``m`` added, simulated, diagnosed (the
    proposal's binding pair refitted); ``(config, record, diagnosis or None)``."""
    concealed = sorted(job["effects"])
    out = {"what": m.get("what"), "settings": m.get("settings")}
    t0 = time.perf_counter()
    tmp = Path(tempfile.mkdtemp(prefix="dpdfit-loop-", dir=workdir))
    refit = _binding_refits(m)
    try:
        cfg = extend_config(cfg, m)
        folder = tmp / "campaign"
        simulate_campaign(folder, seed=job["seed"], config=cfg, progress=False)
        (folder / "truth.json").unlink()                      # the diagnosis never sees it
        left = job.get("forms_left_out")
        d = _diagnose(folder, refit, left) if left else _diagnose(folder, refit)
    except Exception as e:                   # noqa: BLE001 - recorded; the loop stops there
        return cfg, {**out, "error": f"{type(e).__name__}: {e}", "resolved": False,
                     "ambiguous_after": None, "seconds": time.perf_counter() - t0}, None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    amb = ambiguity(d)
    status = _status(d, concealed)
    rec = {**out, "verdict": d.verdict, "named": list(d.named),
           "alternatives": [a.get("named", [a.get("effect")]) for a in amb["alternatives"]],
           "status": status, "resolved": status == "exact" and not amb["ambiguous"],
           "ambiguous_after": amb["ambiguous"],
           "turned_wrong": status == "wrong" and _status(before, concealed) != "wrong",
           "seconds": time.perf_counter() - t0}
    refits = (getattr(d, "extra", None) or {}).get("refits")
    b = (m or {}).get("binding") or {}
    if refit and refits and len(refits) == 2 and "chi2" in b.get("truth", {}):
        rec["separation_predicted"] = float(m.get("expected_delta_bic", float("nan")))
        rec["separation_achieved"] = achieved_separation(
            {"truth": b["truth"]["chi2"], "rival": b["rival"]["chi2"]},
            {"truth": refits[0]["chi2"], "rival": refits[1]["chi2"]})
    return cfg, rec, d


def _arm(job: dict, cfg: CampaignConfig, first, choose, workdir, steps: int) -> dict:
    """Up to ``steps`` recordings, each chosen by ``choose(diagnosis, config)`` (a
    measurement or None) from the latest diagnosis, while it is still ambiguous or wrong.
    The arm's record has the first step's keys at the top (as a one-step loop gives
    them), ``steps`` (every step's record), ``n_steps``, ``resolved_final`` (exact with no
    alternative after the last step) and ``turned_wrong`` (a step turned an exact verdict,
    or one with the truth among its alternatives, into a confidently wrong one)."""
    d, records = first, []
    for _ in range(steps):
        m = choose(d, cfg)
        if m is None or m.get("what") is None:
            break
        cfg, rec, d_new = _step(job, cfg, m, d, workdir)
        records.append(rec)
        if d_new is None or rec["resolved"] or not (rec["ambiguous_after"]
                                                    or rec["status"] != "exact"):
            break
        d = d_new
    if not records:
        return {"what": None, "settings": None, "resolved": False, "ambiguous_after": None,
                "steps": [], "n_steps": 0, "resolved_final": False, "turned_wrong": False,
                "reason": "no measurement was proposed"}
    top = {k: v for k, v in records[0].items()}
    return {**top, "steps": records, "n_steps": len(records),
            "resolved_final": bool(records[-1].get("resolved")),
            "status_final": records[-1].get("status"),
            "turned_wrong": any(r.get("turned_wrong") for r in records)}


#: steps of the closed loop at most: propose, record under the truth, add, diagnose
#: again, and propose again while it is still ambiguous
LOOP_STEPS = 3


def close_loop(job: dict, first, workdir: str | None = None,
               steps: int = LOOP_STEPS) -> dict | None:
    """Take the proposed measurements (and random ones) and diagnose again, up to
    ``steps`` times.

    Parameters
    ----------
    job : dict
        A harness job (:func:`dpdfit.simulation.harness.plan`): ``concealed``,
        ``seed``, ``effects``.
    first : Diagnosis or dict
        The diagnosis of the job's campaign (or its dict, or the run record).
    workdir : str, optional
        Where the temporary campaigns are written.
    steps : int
        Recordings at most per arm (:data:`LOOP_STEPS`).

    Returns
    -------
    dict or None
        None when the diagnosis is neither ambiguous (no alternatives) nor wrong (the
        concealed set, or ``none`` for a null, named).  Else ``{"recommended": arm,
        "random": arm}``.  The recommended arm takes the diagnosis's proposal at each
        step (none when it proposes nothing); the random arm a recording drawn by
        :func:`random_menu_choice` from the proposal's menu (the default menu without
        one), from a stream seeded by the job's seed.  Each arm records its steps
        (``what``, ``settings``, ``verdict``, ``named``, ``alternatives``, ``status``
        exact / in_reach / wrong, ``resolved`` = exact with no alternative left,
        ``turned_wrong``, and for a proposal with a binding pair
        ``separation_predicted`` and ``separation_achieved``), with the first step's keys
        at the top; ``error`` where a campaign could not be simulated or diagnosed.
    """
    amb = ambiguity(first)
    concealed = sorted(job["effects"])
    if not amb["ambiguous"] and _status(first, concealed) == "exact":
        return None
    # imported here: the harness imports this module
    from dpdfit.simulation.harness import harness_config
    cfg = harness_config(job["seed"]).inject(job["effects"])
    rng = np.random.default_rng(np.random.SeedSequence([int(job["seed"]), _RANDOM_KEY]))

    def proposed(d, cfg):
        m = ambiguity(d)["next_measurement"]
        return m if isinstance(m, dict) else None

    def chance(d, cfg):
        return random_menu_choice(rng, ambiguity(d)["next_measurement"], cfg)

    return {"recommended": _arm(job, cfg, first, proposed, workdir, steps),
            "random": _arm(job, cfg, first, chance, workdir, steps)}


def _named_correctly(r: dict) -> bool:
    """A run record's ``named_correctly`` (older records: the verdict is the concealed)."""
    if "named_correctly" in r:
        return bool(r["named_correctly"])
    return r["verdict"] == r["concealed"]


def loop_summary(results: list) -> dict:
    """Ambiguity and closed-loop part of the harness summary.

    Parameters
    ----------
    results : list of dict
        Harness run records (without failed runs); records of older logs without
        the ambiguity keys count as unambiguous.

    Returns
    -------
    dict
        ``ambiguous_rate`` (runs with alternatives), ``confidently_wrong_rate``
        (runs named wrongly -- a null: any verdict but ``none`` -- whose truth is
        not among the alternatives), both over all runs (None without runs), and
        ``closed_loop``: ``n`` (ambiguous or wrong runs whose loop was closed),
        ``resolved_recommended``, ``resolved_random`` (fractions of those exact with no
        alternative after one recording), ``resolved_recommended_final``,
        ``resolved_random_final`` (after the loop's last, at most :data:`LOOP_STEPS`),
        ``turned_wrong_recommended``, ``turned_wrong_random`` (loops in which a recording
        turned an exact verdict, or one with the truth among its alternatives, into a
        confidently wrong one), ``separation_ratios`` (achieved / predicted separation of
        every recommended step with a prediction) and their median
        ``separation_ratio_median``, ``no_proposal`` (loops whose diagnosis proposed
        nothing), ``n_failed`` (re-simulations or re-diagnoses that failed).
    """
    n = len(results)
    wrong = [not _named_correctly(r)
             and not truth_in_reach(r, sorted(r.get("effects") or {})) for r in results]
    loops = [r["closed_loop"] for r in results if r.get("closed_loop")]

    def rate(arm, key="resolved"):
        if not loops:
            return None
        return sum(bool(x[arm].get(key, x[arm].get("resolved"))) for x in loops) / len(loops)

    ratios = [st["separation_achieved"] / st["separation_predicted"]
              for x in loops for st in x["recommended"].get("steps") or ()
              if st.get("separation_achieved") is not None
              and (st.get("separation_predicted") or 0) > 0]
    steps = [st for x in loops for a in ("recommended", "random")
             for st in (x[a].get("steps") or [x[a]])]
    return {"ambiguous_rate": (sum(bool(r.get("alternatives")) for r in results) / n)
            if n else None,
            "confidently_wrong_rate": (sum(wrong) / n) if n else None,
            "closed_loop": {"n": len(loops), "resolved_recommended": rate("recommended"),
                            "resolved_random": rate("random"),
                            "resolved_recommended_final": rate("recommended",
                                                               "resolved_final"),
                            "resolved_random_final": rate("random", "resolved_final"),
                            "turned_wrong_recommended": sum(
                                bool(x["recommended"].get("turned_wrong")) for x in loops),
                            "turned_wrong_random": sum(
                                bool(x["random"].get("turned_wrong")) for x in loops),
                            "separation_ratios": [float(v) for v in ratios],
                            "separation_ratio_median": (float(np.median(ratios)) if ratios
                                                        else None),
                            "no_proposal": sum(x["recommended"].get("what") is None
                                               and not x["recommended"].get("error")
                                               for x in loops),
                            "n_failed": sum("error" in st for st in steps)}}


def loop_report_lines(s: dict) -> list:
    """The harness report's lines on ambiguity and the closed loop.

    Parameters
    ----------
    s : dict
        A harness summary (:func:`dpdfit.simulation.harness.summarise`); the lines
        are empty for a summary without these keys.

    Returns
    -------
    list of str
    """
    def num(v):
        return "n/a" if v is None else f"{v:.3g}"

    if "ambiguous_rate" not in s:
        return []
    cl = s.get("closed_loop") or {}
    lines = [f"  ambiguous: {num(s['ambiguous_rate'])}, confidently wrong: "
             f"{num(s.get('confidently_wrong_rate'))}",
             f"  closed loop ({cl.get('n', 0)} ambiguous with a proposal): resolved to the "
             f"truth by the proposal {num(cl.get('resolved_recommended'))}, by a random "
             f"choice {num(cl.get('resolved_random'))}"
             + (f" ({cl['n_failed']} failed)" if cl.get("n_failed") else "")]
    if "resolved_recommended_final" in cl:
        lines.append(f"    after up to {LOOP_STEPS} recordings: proposal "
                     f"{num(cl.get('resolved_recommended_final'))}, random "
                     f"{num(cl.get('resolved_random_final'))}; turned confidently wrong: "
                     f"proposal {cl.get('turned_wrong_recommended', 0)}, random "
                     f"{cl.get('turned_wrong_random', 0)}; achieved / predicted separation "
                     f"median {num(cl.get('separation_ratio_median'))} over "
                     f"{len(cl.get('separation_ratios') or [])} recordings; no proposal "
                     f"{cl.get('no_proposal', 0)}")
    return lines
