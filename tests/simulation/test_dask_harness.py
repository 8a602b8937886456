"""The harness on a real dask.distributed cluster.

A ``LocalCluster`` on the loopback interface (two worker processes, one thread
each) runs a small harness through ``dpdfit harness --scheduler ADDR``; its runs
must equal those of the local process pool with the same seeds.  A job whose
worker dies is run again by Dask, and one that dies every time is reported as
failed (never dropped).
"""

from __future__ import annotations

import json
import math
import os
import sys
import time

import pytest

distributed = pytest.importorskip(
    "dask.distributed", reason="dask.distributed not installed (pip install 'dpdfit[dask]')")
import cloudpickle  # noqa: E402  (a dependency of distributed)
import dask  # noqa: E402

from dpdfit.cli.main import main  # noqa: E402
from dpdfit.simulation.dispatch import run_jobs  # noqa: E402

# the worker processes get this module's functions by value, whatever sys.path they have
cloudpickle.register_pickle_by_value(sys.modules[__name__])

#: timing fields of a run record: the only ones that may differ between two runs
#: what a run measures of its own speed, which differs between any two runs (the closed
#: loop's re-diagnoses record their ``seconds`` too)
TIMING = {"seconds_simulation", "seconds_diagnosis", "cpu_seconds_diagnosis", "seconds"}


def _cluster():
    return distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                    host="127.0.0.1", dashboard_address=None)


def _square_or_die(job):
    """A test job: ``"die"`` kills its worker process every time, ``"once:PATH"`` only the
    first time (PATH marks that it died once), a number is squared."""
    if job == "die":
        os._exit(1)
    if isinstance(job, str) and job.startswith("once:"):
        if not os.path.exists(job[5:]):
            open(job[5:], "w").close()
            os._exit(1)
        return "survived"
    return job * job


def _same(a, b, path="run"):
    """Equal records: numbers to floating-point tolerance, everything else exactly."""
    if isinstance(a, dict) and isinstance(b, dict):
        assert set(a) == set(b), f"{path}: keys {sorted(set(a) ^ set(b))}"
        for k in a:
            if k not in TIMING:
                _same(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list) and isinstance(b, list):
        assert len(a) == len(b), f"{path}: {len(a)} != {len(b)} items"
        for i, (x, y) in enumerate(zip(a, b)):
            _same(x, y, f"{path}[{i}]")
    elif isinstance(a, float) or isinstance(b, float):
        assert (a is None) == (b is None) and (a is None or math.isclose(
            a, b, rel_tol=1e-9, abs_tol=1e-12) or (math.isnan(a) and math.isnan(b))), \
            f"{path}: {a} != {b}"
    else:
        assert a == b, f"{path}: {a!r} != {b!r}"


@pytest.mark.slow      # also slow: -m "not slow" replaces the default -m 'not cluster'
@pytest.mark.cluster
def test_harness_on_a_dask_cluster_equals_the_process_pool(tmp_path, capsys):
    """``dpdfit harness --scheduler ADDR`` on a LocalCluster: same runs, verdicts and fitted
    parameters as ``--workers 2`` (one concealed AM-to-PM effect and one null)."""
    args = ["harness", "--effects", "am_pm_omitted", "--per-effect", "1", "--nulls", "1",
            "--seed", "7", "--no-progress"]
    t0 = time.perf_counter()
    assert main([*args, "--workers", "2", "-o", str(tmp_path / "pool.json")]) == 0
    t_pool = time.perf_counter() - t0
    with _cluster() as cluster:
        t0 = time.perf_counter()
        assert main([*args, "--scheduler", cluster.scheduler_address,
                     "-o", str(tmp_path / "dask.json")]) == 0
        t_dask = time.perf_counter() - t0
    pool = json.loads((tmp_path / "pool.json").read_text())
    dsk = json.loads((tmp_path / "dask.json").read_text())
    with capsys.disabled():
        print(f"\n[dask harness] 2 runs: process pool {t_pool:.0f} s, Dask LocalCluster "
              f"{t_dask:.0f} s")
    assert pool["n_runs"] == dsk["n_runs"] == 2 and dsk["n_failed"] == 0
    assert dsk["scheduler"].startswith("tcp://127.0.0.1:")
    assert [(r["concealed"], r["seed"]) for r in pool["runs"]] == \
        [(r["concealed"], r["seed"]) for r in dsk["runs"]]
    assert [r["verdict"] for r in pool["runs"]] == [r["verdict"] for r in dsk["runs"]]
    _same(pool["runs"], dsk["runs"])
    for k in ("confusion", "false_alarm_rate", "named_correctly", "recovery"):
        _same(pool[k], dsk[k], k)


@pytest.mark.slow
def test_a_killed_workers_job_is_retried_or_reported():
    """A job that kills its worker once is run again; one that kills it every time is handed
    to ``failed`` as KilledWorker after the allowed failures; the others all finish."""
    import tempfile
    with tempfile.TemporaryDirectory() as d:
        jobs = [1, 2, "die", f"once:{d}/died", 3]
        done, lost = [], []
        # one task at a time per worker (none waits on a worker that another task kills: a
        # dying worker's waiting tasks count as failed tries too); one retry
        cfg = {"distributed.scheduler.allowed-failures": 1,
               "distributed.scheduler.worker-saturation": 1.0}
        with dask.config.set(cfg), _cluster() as c:
            run_jobs(_square_or_die, jobs, None, c.scheduler_address, done.append,
                     lambda job, e: lost.append((job, type(e).__name__)))
    assert sorted(map(str, done)) == ["1", "4", "9", "survived"]
    assert lost == [("die", "KilledWorker")]


def test_a_dead_local_process_fails_its_jobs_loudly():
    """The process pool: a dead worker breaks the pool; every job not finished is handed to
    ``failed`` (none is dropped), and without ``failed`` the error is raised."""
    jobs = [1, "die", 2]
    done, lost = [], []
    run_jobs(_square_or_die, jobs, 2, None, done.append, lambda job, e: lost.append(job))
    assert "die" in lost and len(done) + len(lost) == len(jobs)
    with pytest.raises(Exception):
        run_jobs(_square_or_die, ["die"], 2, None, done.append)


def test_a_failed_run_is_a_record_with_its_error(tmp_path, monkeypatch):
    """The harness reports a failed run as a record with ``error`` (summary, report, log);
    re-running with the same log runs it again."""
    import dpdfit.simulation.harness as H

    def fake_run_one(job, workdir=None):
        if job["concealed"] == "none" and fail:
            raise RuntimeError("worker lost")
        return {**job, "verdict": job["concealed"], "redchi_before": 2.0, "redchi_after": 1.0,
                "seconds_simulation": 0.0, "seconds_diagnosis": 0.0, "ranking": []}

    monkeypatch.setattr(H, "run_one", fake_run_one)
    log = tmp_path / "runs.jsonl"
    kw = dict(per_effect=1, nulls=1, workers=1, seed=5, effects=("dephasing",), progress=False)
    fail = True
    s = H.run_harness(log=log, **kw)
    assert s["n_runs"] == 1 and s["n_failed"] == 1 and len(s["runs"]) == 2
    bad = [r for r in s["runs"] if "error" in r]
    assert bad[0]["concealed"] == "none" and bad[0]["error"] == "RuntimeError: worker lost"
    assert f"FAILED: none seed {bad[0]['seed']}: RuntimeError: worker lost" in H.report(s)
    assert len(log.read_text().splitlines()) == 2
    fail = False
    s2 = H.run_harness(log=log, **kw)
    assert s2["n_runs"] == 2 and s2["n_failed"] == 0
