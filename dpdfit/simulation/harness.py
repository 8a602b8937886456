"""Injection-recovery harness of the discrepancy diagnosis (issue #7).

For each catalog effect, campaigns are simulated with the effect concealed at
a realistic strength (strength, sign and seed drawn from a fixed seed), plus
campaigns with nothing concealed; each is diagnosed as a lab would (the
diagnosis reads only the recordings, never ``truth.json``) and the verdict and
recovered parameters are compared with the truth.

Harness campaigns use :func:`harness_config`: the campaign simulator with the
tone powers taken directly from the field (with the noise the heterodyne
extraction would leave, :func:`dpdfit.simulation.campaign.direct_tones`), three gate
amplitudes x two flags x three scans and two time scans, so that one
injection (simulation + diagnosis) takes ~30 s on one core.

Realistic strengths (:data:`STRENGTHS`, ``(lo, hi)`` of ``|strength|``; sign
random where the effect has one) are chosen so that each effect changes the
recordings at a level a lab would meet: e.g. AOM memory of 40-120 ns (RF
bandwidth of a few MHz), a table 1-3 % stale in A_corr (1-3 sigma of the
run-to-run drift of Supplement S2), 30-150 /s extra dephasing (T2 of 50 ms
degraded to 6-20 ms), 0.05-0.2 quanta/ms heating.

Runs are independent: :func:`run_harness` spreads them over local processes
(``concurrent.futures``) or over a Dask cluster (``scheduler="tcp://..."``,
``pip install dpdfit[dask]``; :mod:`dpdfit.simulation.dispatch`).  The
command line is :mod:`dpdfit.cli.harness`.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from dpdfit.core.progress import job_progress
from dpdfit.errors import InputError
from dpdfit.recordings.outputs import to_jsonable
from dpdfit.simulation.campaign import CampaignConfig, simulate_campaign
from dpdfit.simulation.dispatch import run_jobs

__all__ = ["harness_config", "STRENGTHS", "CONCEALED", "PER_EFFECT", "NULLS", "PLAN_SEED",
           "truth_params", "plan", "run_one", "run_harness", "summarise", "write_report",
           "report"]

#: Default size of the plan: campaigns per concealed effect, null campaigns.
PER_EFFECT = 20
NULLS = 20
#: Default seed of the injection plan.
PLAN_SEED = 7

#: concealed effect -> (campaign effects to set, |strength| range, signed?)
STRENGTHS = {
    "am_pm_omitted": ({"am_pm_omitted": (0.05, 0.15)}, True),
    "aom_memory": ({"aom_memory": (40.0, 120.0), "aom_memory_offset": (1.0, 4.0)}, True),
    "stale_calibration": ({"calibration_drift": (0.01, 0.03)}, True),
    "higher_order_im": ({"higher_order_im": (0.01, 0.03)}, True),
    "detector_nonlinearity": ({"detector_nonlinearity": (0.05, 0.15)}, True),
    "motional_heating": ({"motional_heating": (0.05, 0.2)}, False),
    "dephasing": ({"dephasing": (30.0, 150.0)}, False),
    "spam_offset": ({"spam_offset": (0.005, 0.02)}, False),
    "gate_rate_miscalibration": ({"gate_rate_miscalibration": (0.15, 0.4)}, True),
}
CONCEALED = tuple(STRENGTHS)


def harness_config(seed: int) -> CampaignConfig:
    """The reduced campaign of the harness (see module doc)."""
    return CampaignConfig(seed=seed, spectra_mode="direct", n_amp_runs=3, amp_span_days=5.0,
                          n_phase_runs=2, phase_span_hours=1.0, gate_amplitudes=(0.4, 0.6, 0.8),
                          scan_shots=((625, 625), (625, 625), (625, 625)),
                          time_scan_A=0.6, time_scan_points=13, bundled_traces=())


def truth_params(effect: str, strengths: dict, truth: dict) -> dict:
    """The concealed effect's true parameters in the catalog's units."""
    cal = truth.get("calibration", {})
    if effect == "am_pm_omitted":
        return {"dphi": strengths["am_pm_omitted"]}
    if effect == "aom_memory":
        return {"tau": strengths["aom_memory"], "f_off": strengths["aom_memory_offset"]}
    if effect == "stale_calibration":
        return {"drift": cal["lut_relative_y05"]}
    if effect == "higher_order_im":
        return {"k5": strengths["higher_order_im"]}
    if effect == "detector_nonlinearity":
        return {"k_det": cal["detector_nonlinearity_rel_max"]}
    if effect == "motional_heating":
        return {"ndot": strengths["motional_heating"]}
    if effect == "dephasing":
        return {"gamma": strengths["dephasing"]}
    if effect == "spam_offset":
        return {"p_prep": strengths["spam_offset"]}
    if effect == "gate_rate_miscalibration":
        return {"eps": strengths["gate_rate_miscalibration"]}
    return {}


def plan(per_effect: int = PER_EFFECT, nulls: int = NULLS, seed: int = PLAN_SEED,
         effects=CONCEALED) -> list:
    """The list of injections: dicts with ``concealed``, ``seed``, ``effects``."""
    if per_effect < 0 or nulls < 0 or per_effect + nulls == 0:
        raise InputError(f"need --per-effect >= 0 and --nulls >= 0, not both 0 "
                         f"(got {per_effect} and {nulls})")
    rng = np.random.default_rng(seed)
    jobs = []
    for e in effects:
        if e not in STRENGTHS:
            raise InputError(f"unknown concealed effect '{e}'; known: {', '.join(STRENGTHS)}")
        spec, signed = STRENGTHS[e]
        for _ in range(per_effect):
            sign = rng.choice([-1.0, 1.0]) if signed else 1.0
            eff = {}
            for name, (lo, hi) in spec.items():
                v = float(rng.uniform(lo, hi))
                # memory time is positive; its centre offset carries the sign
                eff[name] = v if name == "aom_memory" else sign * v
            jobs.append({"concealed": e, "seed": int(rng.integers(1, 2 ** 31)), "effects": eff})
    for _ in range(nulls):
        jobs.append({"concealed": "none", "seed": int(rng.integers(1, 2 ** 31)), "effects": {}})
    return jobs


def run_one(job: dict, workdir: str | None = None) -> dict:
    """Simulate one harness campaign, diagnose it, compare with the truth."""
    from dpdfit.analyses.diagnosis.diagnose import diagnose
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    t0 = time.perf_counter()
    tmp = Path(tempfile.mkdtemp(prefix="dpdfit-harness-", dir=workdir))
    try:
        folder = tmp / "campaign"
        truth = simulate_campaign(folder, seed=job["seed"], effects=job["effects"],
                                  config=harness_config(job["seed"]),
                                  progress=False)
        t_sim = time.perf_counter() - t0
        (folder / "truth.json").unlink()                      # the diagnosis never sees it
        d = diagnose(folder, progress=False)          # the harness has its own bar
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    out = {**job, "verdict": d.verdict, "seconds_simulation": t_sim,
           "seconds_diagnosis": d.seconds,
           "redchi_before": _total_redchi(d.baseline), "redchi_after": _total_redchi(
               d.chosen or d.baseline),
           "ranking": [{k: r[k] for k in ("effect", "delta_bic", "p_value", "params",
                                          "params_err")} for r in d.ranking[:4]]}
    if job["concealed"] != "none":
        tp = truth_params(job["concealed"], job["effects"], truth)
        out["truth_params"] = tp
        fit = next((r for r in d.ranking if r["effect"] == job["concealed"]), None)
        if fit is not None:
            out["fit_params"] = fit["params"]
            out["fit_params_err"] = fit["params_err"]
    return out


def _total_redchi(f) -> float:
    return float(f.chi2 / f.dof)


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
                scheduler: str | None = None, seed: int = PLAN_SEED, effects=CONCEALED,
                progress=None, log=None) -> dict:
    """Run the harness; returns the summary (see :func:`summarise`) with all runs.

    ``log``: path of a run log (JSON lines).  Every finished run is appended
    to it at once, so a stopped harness loses nothing; runs of the plan
    already in the log are not run again (re-running the same command resumes).
    ``progress``: None (a bar when stderr is a terminal), True, False, or a
    callback ``progress(k_done, n_jobs)``.
    """
    jobs = plan(per_effect, nulls, seed, effects)
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

        run_jobs(run_one, todo, n_workers, scheduler, finished, failed)
    # plan order, whatever order the runs finished in
    order = {_job_key(j): i for i, j in enumerate(jobs)}
    results.sort(key=lambda r: order[_job_key(r)])
    out = summarise(results)
    out["seconds"] = time.perf_counter() - t0
    out["workers"] = n_workers
    out["scheduler"] = scheduler
    out["seed"] = seed
    out["strengths"] = {k: {n: list(r) for n, r in v[0].items()} for k, v in STRENGTHS.items()}
    return out


def _num(v) -> float:
    """A number from a run record (``None``, JSON's NaN, becomes NaN)."""
    return float("nan") if v is None else float(v)


def _within_2sigma(r: dict) -> bool:
    """Every true parameter within 2 fitted sigma (parameters without an error are skipped)."""
    errs = {k: _num(r["fit_params_err"].get(k)) for k in r["truth_params"]}
    return all(abs((r["fit_params"][k] - t) / errs[k]) <= 2
               for k, t in r["truth_params"].items() if np.isfinite(errs[k]))


def summarise(results: list) -> dict:
    """Confusion matrix, false-alarm rate, recovery (bias, coverage) and fit improvement;
    failed runs (records with ``error``) are counted apart and kept in ``runs``."""
    every, results = results, [r for r in results if "error" not in r]
    labels = sorted({r["concealed"] for r in results})
    confusion = {c: {} for c in labels}
    for r in results:
        row = confusion[r["concealed"]]
        row[r["verdict"]] = row.get(r["verdict"], 0) + 1
    nulls = [r for r in results if r["concealed"] == "none"]
    far = (sum(r["verdict"] != "none" for r in nulls) / len(nulls)) if nulls else None
    named = {}
    for c in labels:
        if c == "none":
            continue
        rs = [r for r in results if r["concealed"] == c]
        named[c] = sum(r["verdict"] == c for r in rs) / len(rs)
    recovery = {}
    for c in labels:
        if c == "none":
            continue
        rs = [r for r in results if r["concealed"] == c and r["verdict"] == c
              and "fit_params" in r]
        per = {}
        for name in (rs[0]["truth_params"] if rs else {}):
            d, pulls = [], []
            for r in rs:
                v, e, t = (r["fit_params"].get(name), r["fit_params_err"].get(name),
                           r["truth_params"].get(name))
                if v is None or t is None:
                    continue
                # f_off's sign and tau are identified together; compare as fitted
                d.append(v - t)
                if e is not None and np.isfinite(e) and e > 0:
                    pulls.append((v - t) / e)
            pulls = np.asarray(pulls)
            per[name] = {"n": len(d), "bias": float(np.mean(d)) if d else None,
                         "median_abs_error": float(np.median(np.abs(d))) if d else None,
                         "coverage_1sigma": float(np.mean(np.abs(pulls) <= 1)) if pulls.size
                         else None,
                         "coverage_2sigma": float(np.mean(np.abs(pulls) <= 2)) if pulls.size
                         else None}
        within2 = [_within_2sigma(r) for r in rs]
        recovery[c] = {"params": per, "n_named": len(rs),
                       "all_params_within_2sigma": float(np.mean(within2)) if within2 else None}
    conc = [r for r in results if r["concealed"] != "none"]
    return {"n_runs": len(results), "n_failed": len(every) - len(results), "confusion": confusion, "false_alarm_rate": far,
            "named_correctly": named,
            "named_correctly_overall": (sum(r["verdict"] == r["concealed"] for r in conc)
                                        / len(conc)) if conc else None,
            "recovery": recovery,
            "median_redchi_before": float(np.median([r["redchi_before"] for r in conc]))
            if conc else None,
            "median_redchi_after": float(np.median([r["redchi_after"] for r in conc]))
            if conc else None,
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
             f"  named correctly overall: {num(s['named_correctly_overall'])}",
             f"  false-alarm rate (nulls): {num(s['false_alarm_rate'])}",
             f"  median reduced chi2 before -> after: {num(s['median_redchi_before'])} -> "
             f"{num(s['median_redchi_after'])}", "", "  confusion (concealed -> named):"]
    for r in (r for r in s["runs"] if "error" in r):
        lines.insert(1, f"  FAILED: {r['concealed']} seed {r['seed']}: {r['error']}")
    for c, row in s["confusion"].items():
        lines.append(f"    {c:>26s}: " + ", ".join(f"{k} {v}" for k, v in sorted(row.items())))
    lines += ["", "  recovery (named cases):"]
    for c, r in s["recovery"].items():
        for p, v in r["params"].items():
            lines.append(f"    {c:>26s} {p:>7s}: n={v['n']} bias={num(v['bias'])} "
                         f"cov1={num(v['coverage_1sigma'])} cov2={num(v['coverage_2sigma'])}")
        lines.append(f"    {c:>26s} all params within 2 sigma: "
                     f"{num(r['all_params_within_2sigma'])}")
    return "\n".join(lines)
