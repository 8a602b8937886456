"""Injection-recovery harness of the discrepancy diagnosis.

Campaigns are simulated with effects of the diagnosis's catalog injected --
one (``per_effect`` campaigns per effect), two or three at once (``pairs``,
``triples`` campaigns: random sets of distinct effects) or none (``nulls``) -- at
realistic strengths (each effect's injection's
:attr:`~dpdfit.simulation.injections.Injection.harness` ranges, drawn by
:meth:`~dpdfit.simulation.injections.Injection.draw` from a fixed seed), by the
injections' own simulator hooks.  Each is diagnosed as a lab
would (the diagnosis reads only the recordings, never ``truth.json``) and the
named effects and their sizes are compared with the truth
(:meth:`~dpdfit.simulation.injections.Injection.truth`): named correctly =
the same set of effects; pulls ``(fitted - injected) / error`` of each
effect's main size (:attr:`~dpdfit.analyses.diagnosis.effects.Effect.main`)
and their 1-sigma coverage.

The leave-one-form-out mode (``leave_one_form_out``) conceals each effect in each
of its forms (``per_form`` campaigns each, strengths per form:
:meth:`~dpdfit.simulation.injections.Injection.harness_table`) and diagnoses it
with that form left out of the catalog (``forms_left_out``): how the diagnosis does
when a lab's physics takes a form the catalog does not have.  The figures per kind
of run are :mod:`dpdfit.simulation.harness_kinds`'s.

Harness campaigns use :func:`~dpdfit.simulation.harness_campaign.harness_config`
(:mod:`dpdfit.simulation.harness_campaign`): a reduced campaign, its tone powers
taken directly from the field.

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

from dpdfit.analyses.diagnosis.diagnose import diagnose
from dpdfit.analyses.diagnosis.effects import EFFECTS, default_effects, get
from dpdfit.core.defaults import (HARNESS_NULLS, HARNESS_PAIRS, HARNESS_PER_EFFECT,
                                  HARNESS_PER_FORM, HARNESS_SEED, HARNESS_TRIPLES)
from dpdfit.core.jsonable import to_jsonable
from dpdfit.core.progress import job_progress
from dpdfit.errors import InputError
from dpdfit.recordings.input_files import read_input_text
from dpdfit.simulation import injections
from dpdfit.simulation.campaign import simulate_campaign
from dpdfit.simulation.closed_loop import ambiguity, close_loop
from dpdfit.simulation.dispatch import run_jobs
from dpdfit.simulation.harness_campaign import harness_config
from dpdfit.simulation.harness_external import spurious_extra, truth_in_reach
from dpdfit.simulation.harness_jobs import (catalog_jobs, form_jobs, mixed_form_jobs,
                                            triple_jobs)
from dpdfit.simulation.harness_summary import report, summarise, write_report

__all__ = ["harness_config", "concealed_effects", "PER_EFFECT", "NULLS", "PAIRS", "TRIPLES",
           "PER_FORM", "PLAN_SEED", "plan", "run_one", "run_harness", "summarise",
           "write_report", "report"]

#: Default size of the plan: campaigns per concealed effect, null campaigns, pairs,
#: triples, and (leave-one-form-out mode) campaigns per form of each effect.
PER_EFFECT = HARNESS_PER_EFFECT
NULLS = HARNESS_NULLS
PAIRS = HARNESS_PAIRS
TRIPLES = HARNESS_TRIPLES
PER_FORM = HARNESS_PER_FORM
#: Default seed of the injection plan.
PLAN_SEED = HARNESS_SEED


def concealed_effects() -> tuple:
    """The effects the harness conceals by default: the registry's default effects whose
    injections have harness strengths (derived from the registries)."""
    return tuple(n for n in default_effects() if injections.get(n).harness)


def plan(per_effect: int = PER_EFFECT, nulls: int = NULLS, seed: int = PLAN_SEED,
         effects=None, pairs: int = PAIRS, triples: int = TRIPLES,
         leave_one_form_out: bool = False, per_form: int = PER_FORM,
         pairs_left_out: int = 0, triples_left_out: int = 0) -> list:
    """The list of injections: dicts with ``concealed`` (an effect, ``a+b``, ``a+b+c`` or
    ``none``), ``seed`` and ``effects`` (``{name: injected values}``).

    The jobs of ``per_effect``, ``nulls`` and ``pairs`` come first, drawn as always from
    ``seed``; then ``triples`` and, with ``leave_one_form_out``, ``per_form`` jobs per
    form of each effect, each from a stream of its own (the triples', and one per effect
    and form), so adding them, or another effect's forms, changes no other job.  A
    left-out-form job also has ``injected_form`` and ``forms_left_out`` (``{effect:
    form}``, ``{effect: [form]}``).  ``pairs_left_out`` and ``triples_left_out``
    campaigns conceal two or three distinct effects at once, each in one of its forms
    drawn at random and left out of the catalog (families of one form excepted: left
    out, they could not be named), each set from a stream of its own.
    """
    effects = concealed_effects() if effects is None else tuple(effects)
    counts = (per_effect, nulls, pairs, triples, pairs_left_out, triples_left_out)
    if min(counts) < 0 or (leave_one_form_out and per_form < 1) or (
            sum(counts) == 0 and not leave_one_form_out):
        raise InputError(f"need --per-effect, --nulls, --pairs, --triples >= 0, not all 0 "
                         f"unless --leave-one-form-out, and --per-form >= 1 (got "
                         f"{per_effect}, {nulls}, {pairs}, {triples}, {per_form})")
    for e in effects:
        if e not in EFFECTS or not injections.get(e).harness:
            known = ", ".join(concealed_effects())
            raise InputError(f"unknown concealed effect '{e}'; known: {known}")
    if pairs and len(effects) < 2:
        raise InputError("pairs need at least two effects")
    if triples and len(effects) < 3:
        raise InputError("triples need at least three effects")
    jobs = catalog_jobs(per_effect, nulls, seed, effects, pairs)
    jobs += triple_jobs(triples, seed, effects)
    if leave_one_form_out:
        jobs += form_jobs(per_form, seed, effects)
    for k, n in ((2, pairs_left_out), (3, triples_left_out)):
        jobs += mixed_form_jobs(n, k, seed, effects)
    return jobs


def run_one(job: dict, workdir: str | None = None, closed_loop: bool = True) -> dict:
    """Simulate one harness campaign, diagnose it, compare with the truth; with
    ``closed_loop``, an ambiguous diagnosis's proposed measurement (and a random one)
    is taken and diagnosed again (:func:`~dpdfit.simulation.closed_loop.close_loop`).

    A job with ``forms_left_out`` is diagnosed with those forms left out.  The record
    holds the job, the verdict and named effects (``named_forms``: the form each was
    named in), ``injected_form`` (``{effect: form}``; the catalog form unless the job
    says), ``forms_left_out`` (``{}`` if none), ``family_left_empty`` (a concealed family
    had no form left to fit), ``forms_fitted`` (the concealed families' forms the
    diagnosis fitted), ``exact_set`` (= ``named_correctly``), ``confidently_wrong``,
    ``spurious_extra``, ``unexplained``, the truth's and the fits' sizes, and times."""
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
        d = diagnose(folder, progress=False,          # the harness has its own bar
                     forms_left_out=job.get("forms_left_out"))
        cpu = time.process_time() - c0                # a paused worker shows wall >> CPU
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    concealed = sorted(job["effects"])
    exact = sorted(d.named) == concealed if concealed else d.verdict == "none"
    left = {e: list(f) for e, f in (job.get("forms_left_out") or {}).items()}
    fitted = {e: [f.name for f in d.context.forms_of(e)] for e in concealed
              if hasattr(d.context, "forms_of")}
    alts = ambiguity(d)["alternatives"]
    rec = {"named": d.named, "verdict": d.verdict, "alternatives": alts}
    out = {**job, "verdict": d.verdict, "named": d.named,
           "named_correctly": exact,
           "named_forms": {x["effect"]: x.get("form") for x in d.effects},
           "injected_form": job.get("injected_form") or {
               e: get(e).forms_for()[0].name for e in concealed},
           "forms_left_out": left,
           "family_left_empty": any(not fitted.get(e, [None]) for e in left),
           "forms_fitted": fitted,
           "exact_set": exact,
           "confidently_wrong": not exact and not truth_in_reach(rec, concealed),
           "spurious_extra": spurious_extra(rec, concealed),
           "unexplained": d.verdict == "unexplained",
           "seconds_simulation": t_sim, "seconds_diagnosis": d.seconds,
           "cpu_seconds_diagnosis": cpu,
           "redchi_before": float(d.baseline.chi2 / d.baseline.dof),
           "redchi_by_observable": d.redchi_before,
           "redchi_after": float((d.chosen or d.baseline).chi2 / (d.chosen or d.baseline).dof),
           "ranking": [{k: r[k] for k in ("effect", "delta_bic", "p_value", "params",
                                          "params_err")} for r in d.ranking[:4]],
           **ambiguity(d), "closed_loop": close_loop(job, d, workdir) if closed_loop else None}
    if concealed:
        out["truth_sizes"] = {e: injections.get(e).truth(injections.get(e).injected(v), truth,
                                                         ctx=d.context)
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
            m = injections.get(e).main_size(out["injected_form"].get(e))
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
    """A job's key in the run log: ``(concealed, seed)``, and the forms it leaves out
    (``"effect:form,..."``) for a left-out-form job, so that the runs of one seed with
    different forms left out are told apart (keys of older logs are unchanged)."""
    left = job.get("forms_left_out") or {}
    if not left:
        return (job["concealed"], int(job["seed"]))
    return (job["concealed"], int(job["seed"]),
            ",".join(f"{e}:{f}" for e in sorted(left) for f in sorted(left[e])))


def _read_log(path: Path) -> dict:
    """Finished runs of a run log (JSON lines), keyed by :func:`_job_key`."""
    done = {}
    if path.exists():
        # a regular file of bounded size: a FIFO or a device in its place is refused unread
        lines = read_input_text(path, what="run log (--log)").splitlines()
        for i, line in enumerate(lines, 1):
            if not line.strip():
                continue
            try:
                r = json.loads(line)
                if "error" not in r:              # a failed run is run again
                    done[_job_key(r)] = r
            except (ValueError, KeyError, TypeError, RecursionError):
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
        # by family: a left-out form's jobs take turns with the other families' too
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
                progress=None, log=None, pairs: int = PAIRS, closed_loop: bool = True,
                triples: int = TRIPLES, leave_one_form_out: bool = False,
                per_form: int = PER_FORM, pairs_left_out: int = 0,
                triples_left_out: int = 0) -> dict:
    """Run the harness; returns the summary (see :func:`summarise`) with all runs.

    The plan is :func:`plan`'s (``triples``, ``leave_one_form_out``, ``per_form``,
    ``pairs_left_out``, ``triples_left_out`` there).

    ``log``: path of a run log (JSON lines).  Every finished run is appended
    to it at once, so a stopped harness loses nothing; runs of the plan
    already in the log are not run again (re-running the same command resumes).
    ``progress``: None (a bar when stderr is a terminal), True, False, or a
    callback ``progress(k_done, n_jobs)``.  ``closed_loop``: take the measurement
    each ambiguous diagnosis proposes, and a random one, and diagnose again.
    """
    jobs = plan(per_effect, nulls, seed, effects, pairs, triples, leave_one_form_out, per_form,
                pairs_left_out, triples_left_out)
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
    out["strengths"] = {k: {n: list(r) for n, r in injections.get(k).harness.items()}
                        for k in concealed_effects()}
    out["strengths_by_form"] = {k: {f: {n: list(r) for n, r in t.items()}
                                    for f, t in injections.get(k).harness_table().items()}
                                for k in concealed_effects()}
    return out
