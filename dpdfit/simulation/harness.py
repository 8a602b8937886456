"""Injection-recovery harness of the discrepancy diagnosis.

Campaigns are simulated with effects of the diagnosis's catalog injected --
one (``per_effect`` campaigns per effect), two at once (``pairs`` campaigns,
random pairs of distinct effects) or none (``nulls``) -- at realistic
strengths (each effect's :attr:`~dpdfit.analyses.diagnosis.effects.Effect.harness`
ranges, drawn by :meth:`~dpdfit.analyses.diagnosis.effects.Effect.draw` from a
fixed seed), by the effects' own simulator hooks.  Each is diagnosed as a lab
would (the diagnosis reads only the recordings, never ``truth.json``) and the
named effects and their sizes are compared with the truth
(:meth:`~dpdfit.analyses.diagnosis.effects.Effect.truth`): named correctly =
the same set of effects; pulls ``(fitted - injected) / error`` of each
effect's main size (:attr:`~dpdfit.analyses.diagnosis.effects.Effect.main`)
and their 1-sigma coverage.

Harness campaigns use :func:`harness_config`: the campaign simulator with the
tone powers taken directly from the field (with the noise the heterodyne
extraction would leave, :func:`dpdfit.simulation.campaign.direct_tones`), three gate
amplitudes x two flags x three scans, two time scans, and calibration runs
before and after the recordings.

Runs are independent: :func:`run_harness` spreads them over local processes
(``concurrent.futures``) or over a Dask cluster (``scheduler="tcp://..."``,
``pip install dpdfit[dask]``; :mod:`dpdfit.simulation.dispatch`).  The
command line is :mod:`dpdfit.cli.harness`.
"""

from __future__ import annotations

import functools
import json
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from dpdfit.analyses.diagnosis.effects import EFFECTS, default_effects, get
from dpdfit.core.jsonable import to_jsonable
from dpdfit.core.progress import job_progress
from dpdfit.errors import InputError
from dpdfit.simulation.campaign import CampaignConfig, simulate_campaign
from dpdfit.simulation.closed_loop import (_named_correctly, ambiguity, close_loop,
                                           loop_report_lines, loop_summary)
from dpdfit.simulation.dispatch import run_jobs

__all__ = ["harness_config", "concealed_effects", "PER_EFFECT", "NULLS", "PAIRS", "PLAN_SEED",
           "plan", "run_one", "run_harness", "summarise", "write_report", "report"]

#: Default size of the plan: campaigns per concealed effect, null campaigns, pairs.
PER_EFFECT = 20
NULLS = 20
PAIRS = 0
#: Default seed of the injection plan.
PLAN_SEED = 7


def concealed_effects() -> tuple:
    """The effects the harness conceals by default: the registry's default effects that
    have harness strengths (derived from the registry)."""
    return tuple(n for n in default_effects() if EFFECTS[n].harness)


def harness_config(seed: int) -> CampaignConfig:
    """The reduced campaign of the harness (see module doc)."""
    return CampaignConfig(seed=seed, spectra_mode="direct", n_amp_runs=9, amp_span_days=14.0,
                          runs_after_recordings=3, n_phase_runs=2, phase_span_hours=1.0,
                          gate_amplitudes=(0.4, 0.6, 0.8),
                          scan_shots=((625, 625), (625, 625), (625, 625)),
                          time_scan_A=0.6, time_scan_points=13, bundled_traces=())


def plan(per_effect: int = PER_EFFECT, nulls: int = NULLS, seed: int = PLAN_SEED,
         effects=None, pairs: int = PAIRS) -> list:
    """The list of injections: dicts with ``concealed`` (an effect, ``a+b`` or
    ``none``), ``seed`` and ``effects`` (``{name: injected values}``)."""
    effects = concealed_effects() if effects is None else tuple(effects)
    if per_effect < 0 or nulls < 0 or pairs < 0 or per_effect + nulls + pairs == 0:
        raise InputError(f"need --per-effect, --nulls, --pairs >= 0, not all 0 "
                         f"(got {per_effect}, {nulls}, {pairs})")
    for e in effects:
        if e not in EFFECTS or not EFFECTS[e].harness:
            known = ", ".join(concealed_effects())
            raise InputError(f"unknown concealed effect '{e}'; known: {known}")
    if pairs and len(effects) < 2:
        raise InputError("pairs need at least two effects")
    rng = np.random.default_rng(seed)
    jobs = []
    for e in effects:
        for _ in range(per_effect):
            jobs.append({"concealed": e, "seed": int(rng.integers(1, 2 ** 31)),
                         "effects": {e: get(e).draw(rng)}})
    for _ in range(nulls):
        jobs.append({"concealed": "none", "seed": int(rng.integers(1, 2 ** 31)), "effects": {}})
    for _ in range(pairs):
        a, b = sorted(rng.choice(len(effects), size=2, replace=False))
        ea, eb = effects[a], effects[b]
        jobs.append({"concealed": f"{ea}+{eb}", "seed": int(rng.integers(1, 2 ** 31)),
                     "effects": {ea: get(ea).draw(rng), eb: get(eb).draw(rng)}})
    return jobs


def run_one(job: dict, workdir: str | None = None, closed_loop: bool = True) -> dict:
    """Simulate one harness campaign, diagnose it, compare with the truth; with
    ``closed_loop``, an ambiguous diagnosis's proposed measurement (and a random one)
    is taken and diagnosed again (:func:`~dpdfit.simulation.closed_loop.close_loop`)."""
    from dpdfit.analyses.diagnosis.diagnose import diagnose
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    t0 = time.perf_counter()
    tmp = Path(tempfile.mkdtemp(prefix="dpdfit-harness-", dir=workdir))
    try:
        folder = tmp / "campaign"
        cfg = harness_config(job["seed"]).inject(job["effects"])
        truth = simulate_campaign(folder, seed=job["seed"], config=cfg, progress=False)
        t_sim = time.perf_counter() - t0
        (folder / "truth.json").unlink()                      # the diagnosis never sees it
        c0 = time.process_time()
        d = diagnose(folder, progress=False)          # the harness has its own bar
        cpu = time.process_time() - c0                # a paused worker shows wall >> CPU
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    concealed = sorted(job["effects"])
    out = {**job, "verdict": d.verdict, "named": d.named,
           "named_correctly": sorted(d.named) == concealed if concealed
           else d.verdict == "none",
           "seconds_simulation": t_sim, "seconds_diagnosis": d.seconds,
           "cpu_seconds_diagnosis": cpu,
           "redchi_before": float(d.baseline.chi2 / d.baseline.dof),
           "redchi_by_observable": d.redchi_before,
           "redchi_after": float((d.chosen or d.baseline).chi2 / (d.chosen or d.baseline).dof),
           "ranking": [{k: r[k] for k in ("effect", "delta_bic", "p_value", "params",
                                          "params_err")} for r in d.ranking[:4]],
           **ambiguity(d), "closed_loop": close_loop(job, d, workdir) if closed_loop else None}
    if concealed:
        out["truth_sizes"] = {e: get(e).truth(get(e).injected(v), truth, ctx=d.context)
                              for e, v in job["effects"].items()}
        out["fit_sizes"] = {}
        for e in concealed:
            # the effect's own fit: as named, else its single fit in the ranking
            named = next((x for x in d.effects if x["effect"] == e), None)
            sizes = named["sizes"] if named else next(
                (r.get("sizes") for r in d.ranking if r["effect"] == e), None)
            if sizes:
                out["fit_sizes"][e] = sizes
        if len(concealed) == 1:
            # the keys of earlier reports: the concealed effect's main size
            e = concealed[0]
            m = get(e).main
            out["truth_params"] = {m: out["truth_sizes"][e].get(m)}
            fs = out["fit_sizes"].get(e, {}).get(m)
            if fs is not None:
                out["fit_params"] = {m: fs["value"]}
                out["fit_params_err"] = {m: fs["error"]}
    return out


class _silent:
    """A progress bar that shows nothing (the ``progress`` factory of harness campaigns)."""

    def __init__(self, *a, **k):
        pass

    def __enter__(self):
        return self

    def __exit__(self, *a):
        return False

    def update(self, *a, **k):
        pass


def _job_key(job: dict) -> tuple:
    return (job["concealed"], int(job["seed"]))


def _read_log(path: Path) -> dict:
    """Finished runs of a run log (JSON lines), keyed by (concealed, seed)."""
    done = {}
    if path.exists():
        lines = path.read_text().splitlines()
        for i, line in enumerate(lines, 1):
            if not line.strip():
                continue
            try:
                r = json.loads(line)
                if "error" not in r:              # a failed run is run again
                    done[_job_key(r)] = r
            except (ValueError, KeyError, TypeError):
                if line.lstrip().startswith("{") and not line.rstrip().endswith("}"):
                    # a record cut by a stop mid-write: that run is simply done again
                    continue
                raise InputError(f"{path}, line {i}: not a harness run record "
                                 f"(is this the right --log file?)") from None
    return done


def _open_log(log) -> tuple[Path | None, dict]:
    """The run log's path and its finished runs; a cut last line is ended so that the
    next record starts afresh."""
    log = None if log is None else Path(log)
    if log is not None and not log.parent.is_dir():
        raise InputError(f"--log {log}: folder {log.parent} does not exist")
    done = {} if log is None else _read_log(log)
    if log is not None and log.exists() and log.stat().st_size:
        with open(log, "rb+") as fh:             # a cut last line: start the next one afresh
            fh.seek(-1, os.SEEK_END)
            if fh.read(1) != b"\n":
                fh.write(b"\n")
    return log, done


def _round_robin(jobs: list, skip: set) -> list:
    """The jobs not in ``skip``, round-robin over the concealed effects (and nulls): any
    prefix of the log, e.g. of a stopped harness, is then a balanced sample."""
    rank, seen = {}, {}
    for j in jobs:
        seen[j["concealed"]] = seen.get(j["concealed"], -1) + 1
        rank[_job_key(j)] = seen[j["concealed"]]
    todo = [j for j in jobs if _job_key(j) not in skip]
    todo.sort(key=lambda j: rank[_job_key(j)])
    return todo


def _append_log(log: Path, record: dict) -> None:
    """Append one finished run to the log at once (flushed to disk)."""
    with open(log, "a") as fh:
        fh.write(json.dumps(to_jsonable(record), sort_keys=True) + "\n")
        fh.flush()
        os.fsync(fh.fileno())


def run_harness(per_effect: int = PER_EFFECT, nulls: int = NULLS, workers: int | None = None,
                scheduler: str | None = None, seed: int = PLAN_SEED, effects=None,
                progress=None, log=None, pairs: int = PAIRS, closed_loop: bool = True) -> dict:
    """Run the harness; returns the summary (see :func:`summarise`) with all runs.

    ``log``: path of a run log (JSON lines).  Every finished run is appended
    to it at once, so a stopped harness loses nothing; runs of the plan
    already in the log are not run again (re-running the same command resumes).
    ``progress``: None (a bar when stderr is a terminal), True, False, or a
    callback ``progress(k_done, n_jobs)``.  ``closed_loop``: take the measurement
    each ambiguous diagnosis proposes, and a random one, and diagnose again.
    """
    jobs = plan(per_effect, nulls, seed, effects, pairs)
    if workers is not None and workers < 1:
        raise InputError(f"--workers must be >= 1, got {workers}")
    t0 = time.perf_counter()
    log, done = _open_log(log)
    by_key = {_job_key(j): done[_job_key(j)] for j in jobs if _job_key(j) in done}
    todo = _round_robin(jobs, set(by_key))
    results = list(by_key.values())

    n_workers = None if scheduler else (workers or os.cpu_count() or 1)
    with job_progress(progress, len(jobs), "harness", initial=len(results)) as update:
        def finished(r):
            results.append(r)
            if log is not None:
                _append_log(log, r)
            update(len(results), len(jobs))

        def failed(job, e):                 # reported as a run record, never dropped
            finished({**job, "error": f"{type(e).__name__}: {e}"})

        fn = run_one if closed_loop else functools.partial(run_one, closed_loop=False)
        run_jobs(fn, todo, n_workers, scheduler, finished, failed)
    # plan order, whatever order the runs finished in
    order = {_job_key(j): i for i, j in enumerate(jobs)}
    results.sort(key=lambda r: order[_job_key(r)])
    out = summarise(results)
    out["seconds"] = time.perf_counter() - t0
    out["workers"] = n_workers
    out["scheduler"] = scheduler
    out["seed"] = seed
    out["strengths"] = {k: {n: list(r) for n, r in EFFECTS[k].harness.items()}
                        for k in concealed_effects()}
    return out


def _num(v) -> float:
    """A number from a run record (``None``, JSON's NaN, becomes NaN)."""
    return float("nan") if v is None else float(v)


def _pulls(rs: list, effect: str) -> dict:
    """Pulls ``(fitted - injected) / error`` of ``effect``'s main size over runs ``rs``."""
    m = get(effect).main
    d, pulls = [], []
    for r in rs:
        t = (r.get("truth_sizes") or {}).get(effect, {}).get(m)
        f = (r.get("fit_sizes") or {}).get(effect, {}).get(m)
        if t is None or f is None or f.get("value") is None:
            continue
        v, e = _num(f["value"]), _num(f.get("error"))
        d.append(v - t)
        if np.isfinite(e) and e > 0:
            pulls.append((v - t) / e)
    pulls = np.asarray(pulls)
    return {"quantity": m, "n": len(d), "bias": float(np.mean(d)) if d else None,
            "median_abs_error": float(np.median(np.abs(d))) if d else None,
            "pulls": [float(x) for x in pulls],
            "coverage_1sigma": float(np.mean(np.abs(pulls) <= 1)) if pulls.size else None,
            "coverage_2sigma": float(np.mean(np.abs(pulls) <= 2)) if pulls.size else None}


def summarise(results: list) -> dict:
    """Confusion matrix, false-alarm rate, named correctly (singles, and both effects
    of pairs), recovery of each effect's main size (bias, pulls, their 1-sigma
    coverage, over the runs that named it), fit improvement, ambiguity and the closed
    loop (:func:`~dpdfit.simulation.closed_loop.loop_summary`); failed runs
    (records with ``error``) are counted apart and kept in ``runs``."""
    every, results = results, [r for r in results if "error" not in r]
    labels = sorted({r["concealed"] for r in results})
    confusion = {c: {} for c in labels}
    for r in results:
        row = confusion[r["concealed"]]
        key = "+".join(sorted(r.get("named") or [])) if "+" in r["concealed"] else r["verdict"]
        key = key or r["verdict"]
        row[key] = row.get(key, 0) + 1
    nulls = [r for r in results if r["concealed"] == "none"]
    far = (sum(r["verdict"] != "none" for r in nulls) / len(nulls)) if nulls else None
    singles = [r for r in results if r["concealed"] != "none" and "+" not in r["concealed"]]
    pairs = [r for r in results if "+" in r["concealed"]]
    named = {}
    for c in labels:
        if c == "none":
            continue
        rs = [r for r in results if r["concealed"] == c]
        named[c] = sum(_named_correctly(r) for r in rs) / len(rs)
    recovery = {}
    for e in sorted({e for r in singles + pairs for e in r.get("effects", {})}):
        # the runs that named the effect (alone or among others)
        rs = [r for r in singles + pairs if e in r.get("effects", {})
              and e in (r.get("named") or [r["verdict"]])]
        main = _pulls(rs, e)
        within = [abs(x) <= 2 for x in main["pulls"]]
        recovery[e] = {"n_named": len(rs), "params": {main["quantity"]: main},
                       "all_params_within_2sigma": float(np.mean(within)) if within
                       else None}
    conc = singles + pairs
    return {"n_runs": len(results), "n_failed": len(every) - len(results),
            "confusion": confusion, "false_alarm_rate": far,
            "named_correctly": named,
            "named_correctly_overall": (sum(_named_correctly(r) for r in singles)
                                        / len(singles)) if singles else None,
            "pairs_both_named": (sum(_named_correctly(r) for r in pairs) / len(pairs))
            if pairs else None,
            "pairs_one_named": (sum(len(set(r.get("named") or []) & set(r["effects"])) >= 1
                                    for r in pairs) / len(pairs)) if pairs else None,
            "recovery": recovery, **loop_summary(results),
            "median_redchi_before": float(np.median([r["redchi_before"] for r in conc]))
            if conc else None,
            "median_redchi_after": float(np.median([r["redchi_after"] for r in conc]))
            if conc else None,
            "median_seconds_diagnosis": float(np.median([r["seconds_diagnosis"]
                                                         for r in results]))
            if results else None,
            "max_seconds_diagnosis": float(np.max([r["seconds_diagnosis"] for r in results]))
            if results else None,
            "median_seconds_per_run": float(np.median([r["seconds_simulation"]
                                                       + r["seconds_diagnosis"]
                                                       for r in results])) if results else None,
            "runs": every}


def write_report(summary: dict, path) -> None:
    """Write the harness summary as JSON (atomically)."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(to_jsonable(summary), indent=1, sort_keys=True) + "\n")
    os.replace(tmp, path)


def report(s: dict) -> str:
    """Readable harness summary."""
    def num(v):
        return "n/a" if v is None else f"{v:.3g}"

    lines = [f"Injection-recovery harness: {s['n_runs']} campaigns in {s['seconds']:.0f} s",
             f"  named correctly (single effects): {num(s['named_correctly_overall'])}",
             f"  pairs, both named: {num(s.get('pairs_both_named'))}, at least one: "
             f"{num(s.get('pairs_one_named'))}",
             f"  false-alarm rate (nulls): {num(s['false_alarm_rate'])}",
             *loop_report_lines(s),
             f"  diagnosis seconds: median {num(s.get('median_seconds_diagnosis'))}, max "
             f"{num(s.get('max_seconds_diagnosis'))}",
             f"  median reduced chi2 before -> after: {num(s['median_redchi_before'])} -> "
             f"{num(s['median_redchi_after'])}", "", "  confusion (concealed -> named):"]
    for r in (r for r in s["runs"] if "error" in r):
        lines.insert(1, f"  FAILED: {r['concealed']} seed {r['seed']}: {r['error']}")
    for c, row in s["confusion"].items():
        lines.append(f"    {c:>40s}: " + ", ".join(f"{k} {v}" for k, v in sorted(row.items())))
    lines += ["", "  recovery of each effect's main size (runs that named it):"]
    for c, r in s["recovery"].items():
        for q, m in r["params"].items():
            lines.append(f"    {c:>26s} {q:>20s}: n={m['n']} bias={num(m['bias'])} "
                         f"cov1={num(m['coverage_1sigma'])} cov2={num(m['coverage_2sigma'])}")
    return "\n".join(lines)
