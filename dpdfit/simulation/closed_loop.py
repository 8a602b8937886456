"""The closed loop of the harness: take the measurement the diagnosis asks for, diagnose again.

When the diagnosis cannot decide between catalog effects it lists the
``alternatives`` and proposes a ``next_measurement`` (one further recording,
chosen from a ``menu``).  :func:`close_loop` simulates that recording under the
campaign's truth, adds it to the campaign and diagnoses again -- and does the
same for a recording chosen at random from the menu
(:func:`~dpdfit.simulation.further_recordings.random_menu_choice`),
the comparison that says whether the proposal is better than chance.

A further recording is a campaign config with one more entry
(:func:`~dpdfit.simulation.further_recordings.extend_config`), drawn from random
streams of its own: every recording the campaign already had is drawn exactly as
before, so the re-diagnosed campaign is the first one plus the new rows.  The loop
takes up to :data:`LOOP_STEPS` recordings per arm, proposing again while the
diagnosis is still ambiguous.  :func:`loop_summary` is the harness summary's part on
ambiguity and on the closed loop.
"""

from __future__ import annotations

import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from dpdfit.analyses.diagnosis.comparison.refits import (achieved_separation, binding_chi2,
                                                         binding_refits, refitted_chi2)
from dpdfit.analyses.diagnosis.diagnose import diagnose
from dpdfit.simulation.campaign import CampaignConfig, simulate_campaign
from dpdfit.simulation.further_recordings import extend_config, random_menu_choice
from dpdfit.simulation.harness_campaign import harness_config
from dpdfit.simulation.harness_external import truth_in_reach
from dpdfit.simulation.harness_kinds import named_correctly

__all__ = ["LOOP_STEPS", "close_loop", "ambiguity", "loop_summary", "loop_report_lines"]

#: Random stream of the random choice: ``SeedSequence([job seed, this])``.
_RANDOM_KEY = 8_101


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
    # a job's left-out forms stay left out of the diagnosis after the further recording
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


def _step(job: dict, cfg: CampaignConfig, m: dict, before, workdir) -> tuple:
    """One recording: the campaign config with ``m`` added, simulated, diagnosed (the
    proposal's binding pair refitted); ``(config, record, diagnosis or None)``."""
    concealed = sorted(job["effects"])
    out = {"what": m.get("what"), "settings": m.get("settings"),
           "lab_seconds": _lab_seconds(m)}
    t0 = time.perf_counter()
    tmp = Path(tempfile.mkdtemp(prefix="dpdfit-loop-", dir=workdir))
    refit = binding_refits(m)
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
    b = (m or {}).get("binding") or {}
    chi2_before = binding_chi2(m)
    chi2_after = refitted_chi2(m, (getattr(d, "extra", None) or {}).get("refits"))
    if chi2_before is not None and chi2_after is not None:
        rec["separation_predicted"] = float(m.get("expected_delta_bic", float("nan")))
        # a prediction is tested only where one of its pair is the concealed set: then
        # against the separation expected if that one is true (the binding direction's,
        # or the reverse one's)
        held = [r for r in ("truth", "rival")
                if sorted(b[r].get("effects") or []) == concealed
                and b[r].get("expected_delta_bic") is not None]
        rec["premise_held"] = bool(held)
        if held:
            rec["separation_predicted_for_truth"] = float(b[held[0]]["expected_delta_bic"])
            # the replicates' 10th percentile under that side: the figure that promises
            p10 = (((m.get("replicates") or {}).get(held[0])) or {}).get("p10")
            if p10 is not None:
                rec["separation_p10_for_truth"] = float(p10)
        rec["separation_achieved"] = achieved_separation(chi2_before, chi2_after)
    return cfg, rec, d


def _lab_seconds(m: dict) -> float | None:
    """The lab time a recording asks for (its ``lab_seconds``; None without one)."""
    try:
        v = float(m.get("lab_seconds"))
    except (TypeError, ValueError):
        return None
    return v if np.isfinite(v) else None


def _seconds_to_resolution(arm: dict) -> float | None:
    """The lab time of an arm's recordings up to the one that resolved it (None when it
    was not resolved or a step has no lab time)."""
    total = 0.0
    for st in arm.get("steps") or [arm]:
        if st.get("lab_seconds") is None:
            return None
        total += float(st["lab_seconds"])
        if st.get("resolved"):
            return total
    return None


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
    cfg = harness_config(job["seed"]).inject(job["effects"])
    rng = np.random.default_rng(np.random.SeedSequence([int(job["seed"]), _RANDOM_KEY]))

    def proposed(d, cfg):
        m = ambiguity(d)["next_measurement"]
        return m if isinstance(m, dict) else None

    def chance(d, cfg):
        return random_menu_choice(rng, ambiguity(d)["next_measurement"], cfg)

    return {"recommended": _arm(job, cfg, first, proposed, workdir, steps),
            "random": _arm(job, cfg, first, chance, workdir, steps)}


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
        ``separation_ratio_median``, the same of the steps one of whose pair was the
        concealed set (``premise_held`` on the step), against the separation expected if
        that one is true (``separation_predicted_for_truth``),
        ``separation_ratios_premise_held`` and
        ``separation_ratio_median_premise_held``, ``p10_held`` (the fraction of those
        steps whose achieved separation reached the 10th percentile of the proposal's
        replicates under the concealed side, ``separation_p10_for_truth``; ``n_p10``
        such steps), ``lab_seconds_to_resolution_recommended`` and ``_random`` (median
        lab time of the recordings up to resolution, over the loops each arm resolved),
        ``no_proposal`` (loops whose diagnosis proposed
        nothing), ``n_failed`` (re-simulations or re-diagnoses that failed).
    """
    n = len(results)
    wrong = [not named_correctly(r)
             and not truth_in_reach(r, sorted(r.get("effects") or {})) for r in results]
    loops = [r["closed_loop"] for r in results if r.get("closed_loop")]

    def rate(arm, key="resolved"):
        if not loops:
            return None
        return sum(bool(x[arm].get(key, x[arm].get("resolved"))) for x in loops) / len(loops)

    predicted = [st for x in loops for st in x["recommended"].get("steps") or ()
                 if st.get("separation_achieved") is not None
                 and (st.get("separation_predicted") or 0) > 0]
    ratios = [st["separation_achieved"] / st["separation_predicted"] for st in predicted]
    held = [st["separation_achieved"] / st["separation_predicted_for_truth"]
            for st in predicted if st.get("premise_held")
            and (st.get("separation_predicted_for_truth") or 0) > 0]
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
                            "separation_ratios_premise_held": [float(v) for v in held],
                            "separation_ratio_median_premise_held": (
                                float(np.median(held)) if held else None),
                            **_promises_and_lab_time(loops, predicted),
                            "no_proposal": sum(x["recommended"].get("what") is None
                                               and not x["recommended"].get("error")
                                               for x in loops),
                            "n_failed": sum("error" in st for st in steps)}}


def _promises_and_lab_time(loops: list, predicted: list) -> dict:
    """``p10_held`` and ``n_p10`` over the predicted steps whose premise held, and each
    arm's median lab time to resolution (:func:`loop_summary`)."""
    promised = [st for st in predicted if st.get("premise_held")
                and st.get("separation_p10_for_truth") is not None]
    out = {"p10_held": (sum(st["separation_achieved"] >= st["separation_p10_for_truth"]
                            for st in promised) / len(promised) if promised else None),
           "n_p10": len(promised)}
    for arm in ("recommended", "random"):
        t = [v for v in (_seconds_to_resolution(x[arm]) for x in loops) if v is not None]
        out[f"lab_seconds_to_resolution_{arm}"] = float(np.median(t)) if t else None
    return out


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
                     f"{len(cl.get('separation_ratios') or [])} recordings ("
                     f"{num(cl.get('separation_ratio_median_premise_held'))} over the "
                     f"{len(cl.get('separation_ratios_premise_held') or [])} whose premise "
                     "held); no proposal "
                     f"{cl.get('no_proposal', 0)}")
    if cl.get("n_p10"):
        lines.append(f"    achieved at or above the replicates' 10th percentile: "
                     f"{round(cl['p10_held'] * cl['n_p10'])} of {cl['n_p10']} recordings "
                     "whose premise held")
    if "lab_seconds_to_resolution_recommended" in cl:
        def hours(v):
            return "n/a" if v is None else f"{v / 3600:.3g} h"
        lines.append(f"    lab time to resolution, median: proposal "
                     f"{hours(cl.get('lab_seconds_to_resolution_recommended'))}, random "
                     f"{hours(cl.get('lab_seconds_to_resolution_random'))}")
    return lines
