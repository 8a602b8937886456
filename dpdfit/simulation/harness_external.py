"""External injection recovery: diagnose campaigns someone else wrote.

``dpdfit harness --campaigns DIR --truth FILE`` diagnoses every campaign folder
in ``DIR`` (a sub-folder holding ``campaign.json``, in name order) exactly as a
lab would -- the diagnosis reads the recordings only -- and compares each
verdict with ``FILE``: JSON, campaign id (the folder's name) -> object with at
least ``effect`` (``"none"`` for a campaign with nothing concealed; other keys
are kept in the report as they are) and, for several concealed effects,
``effects`` (their list): then named correctly = the diagnosis names the same
set of effects.  A campaign without a truth entry is
diagnosed and reported with truth ``"unknown"`` (it counts in neither rate).
A diagnosis that refuses the campaign is recorded with verdict ``"refused"``
and its one-line error, never a crash.  Nothing is written into ``DIR``.

Report keys (keep): ``confusion`` (truth -> verdict -> count),
``false_alarm_rate`` (nulls not called ``none``), ``named_correctly``
(fraction of the concealed campaigns whose verdict is the truth's effect),
``n_campaigns``, ``runs`` (per campaign ``campaign``, ``truth``, ``verdict``,
``seconds``, plus ``named``, ``named_correctly``, ``verdict_fit``, ``params``,
``params_err``, ``sizes``, ``error``, ``alternatives``, ``next_measurement``,
``redchi_before``); with several concealed effects also ``pairs_both_named`` and
``pairs_one_named``.  Added: ``ambiguous`` (campaigns with alternatives in reach),
``confidently_wrong`` (named wrongly with the truth's set neither named nor among the
alternatives) and ``spurious_extra`` (every concealed effect named, and more).
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np

from dpdfit.analyses.diagnosis.diagnose import diagnose
from dpdfit.core.progress import job_progress
from dpdfit.errors import DpdfitError, InputError
from dpdfit.recordings.input_files import read_input_json
from dpdfit.simulation.dispatch import run_jobs

__all__ = ["read_truth", "truth_effects", "campaign_folders", "run_external_one", "summarise_external",
           "truth_in_reach", "spurious_extra",
           "run_external", "report_external"]


def read_truth(path) -> dict:
    """The truth file: campaign id -> object with ``effect`` (InputError naming what is wrong)."""
    path = Path(path)
    if not os.path.lexists(path):
        raise InputError("truth file does not exist", file=str(path))
    # a regular file, bounded in size and depth (a FIFO or a device refused, not read)
    truth = read_input_json(path, what="truth file", not_json="not valid JSON")
    if not isinstance(truth, dict):
        raise InputError("must hold a JSON object: campaign id -> {\"effect\": ...}",
                         file=str(path))
    for cid, v in truth.items():
        if not isinstance(v, dict) or not isinstance(v.get("effect"), str):
            raise InputError(f"campaign {cid!r}: needs an object with a string 'effect'",
                             file=str(path))
        eff = v.get("effects")
        if eff is not None and not (isinstance(eff, list) and eff
                                    and all(isinstance(e, str) for e in eff)):
            raise InputError(f"campaign {cid!r}: 'effects' must be a list of effect names",
                             file=str(path))
    return truth


def truth_effects(entry: dict) -> list:
    """The concealed effects of a truth entry: its ``effects`` list, else ``[effect]``
    (``[]`` for ``"none"``)."""
    if entry.get("effects"):
        return sorted(entry["effects"])
    e = entry.get("effect", "unknown")
    return [] if e == "none" else [e]


def campaign_folders(directory) -> list[Path]:
    """Campaign folders of ``directory`` (sub-folders with ``campaign.json``), by name."""
    directory = Path(directory)
    if not directory.is_dir():
        raise InputError("campaigns folder does not exist", file=str(directory))
    out = sorted(p for p in directory.iterdir() if (p / "campaign.json").is_file())
    if not out:
        raise InputError("no campaign folders (sub-folders with campaign.json) in it",
                         file=str(directory))
    return out


def run_external_one(job: dict) -> dict:
    """Diagnose one campaign folder; ``job`` = ``{"campaign", "folder", "truth"}``."""
    t0 = time.perf_counter()
    rec = {"campaign": job["campaign"], "truth": job["truth"]}
    job = {**job, "effects": job.get("effects")}
    try:
        d = diagnose(job["folder"], progress=False)   # the harness has its own bar
    except DpdfitError as exc:
        return {**rec, "verdict": "refused", "error": str(exc),
                "seconds": time.perf_counter() - t0}
    chosen = d.chosen
    want = job.get("effects")
    return {**rec, "verdict": d.verdict, "seconds": d.seconds, "named": d.named,
            "named_correctly": (None if want is None else
                                sorted(d.named) == want if want else d.verdict == "none"),
            "sizes": {e["effect"]: e["sizes"] for e in d.effects},
            "fidelity_cost": {e["effect"]: [e["fidelity_cost"], e["fidelity_cost_err"]]
                              for e in d.effects},
            "verdict_fit": d.extra.get("verdict_fit"),
            "explained_fraction": d.extra.get("explained_fraction"),
            "params": None if chosen is None else chosen.params,
            "params_err": None if chosen is None else chosen.params_err,
            "alternatives": d.extra.get("alternatives") or [],
            "next_measurement": d.extra.get("next_measurement"),
            "redchi_before": d.redchi_before,
            "left_out": d.extra.get("left_out"), "error": None}


def truth_in_reach(r: dict, truth: list) -> bool:
    """Whether the truth's set of effects is the named set or one of the alternatives'
    (``truth`` sorted; empty for a null, which is in reach only as verdict ``none``)."""
    if not truth:
        return r.get("verdict") == "none"
    if sorted(r.get("named") or []) == truth:
        return True
    return any(sorted(a.get("named") or []) == truth for a in r.get("alternatives") or [])


def spurious_extra(r: dict, truth: list) -> bool:
    """The named set holds every concealed effect and more."""
    named = set(r.get("named") or [])
    return bool(truth) and set(truth) < named


def summarise_external(runs: list) -> dict:
    """Confusion, false-alarm rate and fraction named correctly of diagnosed campaigns."""
    confusion: dict = {}
    for r in runs:
        row = confusion.setdefault(r["truth"], {})
        key = ("+".join(sorted(r.get("named") or [])) or r["verdict"]) if "+" in r["truth"] \
            else r["verdict"]
        row[key] = row.get(key, 0) + 1
    nulls = [r for r in runs if r["truth"] == "none"]
    conc = [r for r in runs if r["truth"] not in ("none", "unknown") and "+" not in r["truth"]]
    pairs = [r for r in runs if "+" in r["truth"]]

    def ok(r):
        return r["named_correctly"] if r.get("named_correctly") is not None \
            else r["verdict"] == r["truth"]

    secs = [r["seconds"] for r in runs]
    known = [r for r in runs if r["truth"] != "unknown" and r["verdict"] != "refused"]

    def truth_of(r):
        return [] if r["truth"] == "none" else sorted(r["truth"].split("+"))

    out = {"n_campaigns": len(runs), "confusion": confusion,
           "ambiguous": sum(bool(r.get("alternatives")) for r in known),
           "confidently_wrong": sum(not ok(r) and not truth_in_reach(r, truth_of(r))
                                    for r in known),
           "spurious_extra": sum(spurious_extra(r, truth_of(r)) for r in known),
            "false_alarm_rate": (sum(r["verdict"] != "none" for r in nulls) / len(nulls)
                                 if nulls else None),
            "named_correctly": (sum(ok(r) for r in conc) / len(conc)
                                if conc else None),
            "n_nulls": len(nulls), "n_concealed": len(conc),
            "n_refused": sum(r["verdict"] == "refused" for r in runs),
            "median_seconds": float(np.median(secs)) if secs else None,
            "max_seconds": float(np.max(secs)) if secs else None,
            "runs": runs}
    if pairs:
        out["n_pairs"] = len(pairs)
        out["pairs_both_named"] = sum(ok(r) for r in pairs) / len(pairs)
        out["pairs_one_named"] = sum(
            len(set(r.get("named") or []) & set(r["truth"].split("+"))) >= 1
            for r in pairs) / len(pairs)
        out["pairs_called_none"] = sum(r["verdict"] == "none" for r in pairs)
    return out


def run_external(directory, truth_file, workers: int | None = None,
                 scheduler: str | None = None, progress=None) -> dict:
    """Diagnose every campaign of ``directory`` and compare with ``truth_file`` (module doc)."""
    truth = read_truth(truth_file)
    folders = campaign_folders(directory)
    if workers is not None and workers < 1:
        raise InputError(f"--workers must be >= 1, got {workers}")
    jobs = []
    for p in folders:
        entry = truth.get(p.name, {})
        eff = truth_effects(entry) if entry else None
        label = entry.get("effect", "unknown") if entry else "unknown"
        if eff and len(eff) > 1:
            label = "+".join(eff)
        jobs.append({"campaign": p.name, "folder": str(p), "truth": label, "effects": eff})
    t0 = time.perf_counter()
    runs = []

    # one worker (the default): one campaign at a time, each diagnosis using the cores
    # itself (dpdfit.core.parallel); more: one diagnosis per worker, serial inside
    n_workers = None if scheduler else (workers or 1)
    with job_progress(progress, len(jobs), "harness") as update:
        def finished(r):
            runs.append(r)
            update(len(runs), len(jobs))

        run_jobs(run_external_one, jobs, n_workers, scheduler, finished)
    order = {j["campaign"]: i for i, j in enumerate(jobs)}
    runs.sort(key=lambda r: order[r["campaign"]])
    out = summarise_external(runs)
    out.update({"campaigns": str(directory), "truth_file": str(truth_file),
                "seconds": time.perf_counter() - t0, "workers": n_workers,
                "scheduler": scheduler})
    return out


def report_external(s: dict) -> str:
    """Readable summary of an external run."""
    def num(v):
        return "n/a" if v is None else f"{v:.3g}"

    def share(frac, n):
        """A fraction of ``n`` campaigns as a count and a percentage."""
        if frac is None or not n:
            return f"n/a of {n or 0}"
        return f"{round(frac * n)}/{n} ({100 * frac:.0f} %)"

    lines = [f"External injection recovery: {s['n_campaigns']} campaigns from "
             f"{s['campaigns']} in {s['seconds']:.0f} s",
             f"  named correctly: {share(s['named_correctly'], s['n_concealed'])} concealed",
             f"  false alarms: {share(s['false_alarm_rate'], s['n_nulls'])} nulls"]
    if s.get("n_pairs"):
        n = s.get("n_pairs")
        lines.append(f"  pairs: both named {share(s.get('pairs_both_named'), n)}, at least one "
                     f"{share(s.get('pairs_one_named'), n)}, called none "
                     f"{s.get('pairs_called_none')}/{n}")
    if "ambiguous" in s:
        lines.append(f"  ambiguous (alternatives in reach): {s['ambiguous']}; confidently "
                     f"wrong (truth not named nor among the alternatives): "
                     f"{s['confidently_wrong']}; spurious extra effect: {s['spurious_extra']}")
    lines += [f"  refused: {s['n_refused']}; seconds per campaign: median "
              f"{num(s['median_seconds'])}, max {num(s['max_seconds'])}", "",
              "  confusion (truth -> named):"]
    for t, row in sorted(s["confusion"].items()):
        lines.append(f"    {t:>26s}: " + ", ".join(f"{k} {v}" for k, v in sorted(row.items())))
    lines += ["", "  runs:"]
    for r in s["runs"]:
        good = (r["named_correctly"] if r.get("named_correctly") is not None
                else r["verdict"] == r["truth"])
        mark = "ok" if good else "--"
        extra = f"  ({r['error']})" if r.get("error") else (
            f"  [{r['verdict_fit']}]" if r.get("verdict_fit") not in (None, "acceptable",
                                                                     "none") else "")
        named = "+".join(r.get("named") or []) or r["verdict"]
        alts = r.get("alternatives") or []
        if alts:
            extra += "  or " + " | ".join("+".join(a["named"]) for a in alts)
        lines.append(f"    {mark} {r['campaign']:>8s}: truth {r['truth']:<40s} named "
                     f"{named:<40s} {r['seconds']:6.1f} s{extra}")
    return "\n".join(lines)
