#!/usr/bin/env python
"""How `dpdfit analyze` scales with the size of a campaign, and trace analysis with trace length.

    python benchmarks/scale.py                       # 1x, 4x, 16x without the diagnosis
    python benchmarks/scale.py --sizes 1,4 --diagnosis
    python benchmarks/scale.py --traces-only --out report.json
    python benchmarks/scale.py --json benchmarks/scale.json   # also the common JSON record

Campaigns k x the bundled one (``datasets/synthetic_campaign``), cached under
``/tmp/dpdfit-scale`` (``--cache``), are built as follows:

* calibration runs: simulated by ``simulate_campaign`` with
  ``n_amp_runs = 34 k`` and ``n_phase_runs = 6 k`` (same span of days/hours:
  denser runs); at k = 1 these files are the bundled ones byte for byte;
* spectra: the amplitude grid refined k-fold (``38 k + 1`` amplitudes on
  0.05..1, so A = 0.5 stays on the grid), tone powers by the simulator's
  ``spectra_mode="direct"`` (the exact tones plus the noise the trace
  extraction would add; the trace synthesis of 16 x 78 traces would take
  hours here);
* gates: the bundled settings (5 A x 2 flags) measured in ``4 k`` scans
  instead of 4: scans 1-4 are the bundled counts, further scans redraw each
  bundled scan's counts (multinomial / binomial with the bundled frequencies,
  same shots).  The exact gate simulation of 16 x the settings would take
  ~1 h on this machine, so settings are not multiplied; ``gate_rates.csv``
  and ``time_scans.csv`` are the bundled ones;
* raw traces: the two bundled 2^21-sample traces (constant); trace length is
  measured separately.

Each analysis runs in a fresh child process (``analyze(folder, plots=False)``,
nothing written).  Per step (``dpdfit.pipeline.analyze._guarded`` wrapped):
wall time, and the peak of Python/numpy allocations traced by
:mod:`tracemalloc` above the step's starting level (reset per step).  Time
and memory come from separate child runs (tracemalloc slows allocation-heavy
code), each ``--repeat`` times (medians).  Also the child's peak resident
memory (``ru_maxrss``, includes imports).  Growth exponent: least-squares
slope of log(value) against log(k) over the sizes run (target <= 1.1).

Trace length: ``.npz`` int16 traces of 2^20, 2^22, 2^24 samples (the
bundled format) analysed by ``load_trace`` + ``trace_tone_powers`` in a child
process each (time, tracemalloc peak, ru_maxrss).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from record import add_json_option, summary_line, write_record

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))
BUNDLED = ROOT / "datasets" / "synthetic_campaign"
STAGES = ("calibration", "stability", "sweep", "spectra", "traces", "gates", "propagation",
          "budget", "diagnosis")
SEED = 20260329


# ----------------------------------------------------------------------------- campaigns
def _more_scans(k: int, rng) -> tuple[pd.DataFrame, pd.DataFrame]:
    """populations.csv, parity.csv with 4 k scans: the bundled ones and k - 1 redraws."""
    pop = pd.read_csv(BUNDLED / "populations.csv")
    par = pd.read_csv(BUNDLED / "parity.csv")
    nscan = int(pop["scan"].max())
    pops, pars = [pop], [par]
    for j in range(1, k):
        p = pop.copy()
        probs = p[["n00", "n01_10", "n11"]].to_numpy(float) / p["shots"].to_numpy()[:, None]
        counts = np.array([rng.multinomial(n, q / q.sum()) for n, q in zip(p["shots"], probs)])
        p[["n00", "n01_10", "n11"]] = counts
        p["n_even"] = counts[:, 0] + counts[:, 2]
        p["scan"] += j * nscan
        q = par.copy()
        q["n_even"] = rng.binomial(q["shots"], q["n_even"] / q["shots"])
        q["scan"] += j * nscan
        pops.append(p)
        pars.append(q)
    return pd.concat(pops, ignore_index=True), pd.concat(pars, ignore_index=True)


def build_campaign(k: int, cache: Path) -> Path:
    """The k x campaign (cached); returns its folder."""
    from dpdfit.simulation.campaign.config import CampaignConfig
    from dpdfit.simulation.campaign.folder import csv_text
    from dpdfit.simulation.campaign.simulate import simulate_campaign
    out = cache / f"campaign_{k}x"
    if (out / "populations.csv").exists():
        return out
    if out.exists():
        shutil.rmtree(out)
    cfg = CampaignConfig(seed=SEED, n_amp_runs=34 * k, n_phase_runs=6 * k, spectra_mode="direct",
                         trace_amplitudes=tuple(np.round(np.linspace(0.05, 1.0, 38 * k + 1), 4)),
                         bundled_traces=())
    t0 = time.perf_counter()
    tmp = cache / f".building_{k}x"
    if tmp.exists():
        shutil.rmtree(tmp)
    simulate_campaign(tmp, config=cfg, progress=False, include_gates=False)
    shutil.copytree(BUNDLED / "traces", tmp / "traces", dirs_exist_ok=True)
    for f in ("traces.csv", "gate_rates.csv", "time_scans.csv"):
        shutil.copy(BUNDLED / f, tmp / f)
    pop, par = _more_scans(k, np.random.default_rng([SEED, 17, k]))
    (tmp / "populations.csv").write_text(csv_text(pop))
    (tmp / "parity.csv").write_text(csv_text(par))
    tmp.rename(out)
    print(f"built {out} in {time.perf_counter() - t0:.0f} s", flush=True)
    return out


def campaign_size(folder: Path) -> dict:
    """Rows per recording file and bytes on disk."""
    rows = {f.name: sum(1 for _ in open(f)) - 1 for f in sorted(folder.glob("*.csv"))}
    size = sum(f.stat().st_size for f in folder.rglob("*") if f.is_file())
    return {"rows": rows, "bytes": size}


# ----------------------------------------------------------------------------- child runs
def _child_analyze(folder: str, diagnosis: bool, trace_mem: bool) -> dict:
    """In the child: run analyze with every step timed (and traced); JSON-able result."""
    import resource
    import tracemalloc

    import dpdfit.pipeline.analyze as an
    stages: dict = {}
    orig = an._guarded

    def guarded(ctx, failures, name, step, *args):
        base = 0
        if trace_mem:
            tracemalloc.reset_peak()
            base = tracemalloc.get_traced_memory()[0]
        t0 = time.perf_counter()
        try:
            return orig(ctx, failures, name, step, *args)
        finally:
            rec = {"time_s": time.perf_counter() - t0}
            if trace_mem:
                rec["peak_bytes"] = tracemalloc.get_traced_memory()[1] - base
            stages[name] = rec

    an._guarded = guarded
    if trace_mem:
        tracemalloc.start()
    t0 = time.perf_counter()
    res = an.analyze(folder, plots=False, diagnosis=diagnosis, progress=False)
    total = time.perf_counter() - t0
    out = {"stages": stages, "total_s": total,
           "maxrss_bytes": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
           # the largest worker process (the diagnosis fits in a process pool)
           "workers_maxrss_bytes": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024,
           "status": {k: v.get("status") if isinstance(v, dict) else v
                      for k, v in res.summary.get("analyses", {}).items()},
           "failures": res.summary.get("failures", [])}
    if trace_mem:
        out["traced_peak_bytes"] = tracemalloc.get_traced_memory()[1]
    return out


def _write_trace(n: int, path: Path) -> None:
    """A 2^m-sample int16 .npz beat trace in the bundled format (volts = trace * scale)."""
    from dpdfit.simulation.beat_trace import simulate_beat_trace
    nu, xi0, f_det, fs = 1.84e6, 20e3, 20e6, 1e9
    rng = np.random.default_rng(n)
    tones = [(s * (nu + h * xi0), a, rng.uniform(0, 2 * np.pi))
             for s in (-1, 1) for h, a in {0: 0.03, 1: 1.0, 2: 0.6, 3: 0.05}.items()]
    x = simulate_beat_trace(fs, n, f_det, tones, 0.015, rng=n)
    scale = float(np.max(np.abs(x))) / 32000.0
    np.savez(path, trace=np.round(x / scale).astype(np.int16), scale=np.array(scale))


def _child_trace(path: str, trace_mem: bool) -> dict:
    import resource
    import tracemalloc

    from dpdfit.fits.tones import trace_tone_powers
    from dpdfit.recordings.traces import load_trace
    if trace_mem:
        tracemalloc.start()
    t0 = time.perf_counter()
    x = load_trace(path)
    t1 = time.perf_counter()
    res = trace_tone_powers(x, 1e9, 20e6, 1.84e6, 20e3)
    t2 = time.perf_counter()
    out = {"n_samples": int(x.size), "load_s": t1 - t0, "tones_s": t2 - t1, "total_s": t2 - t0,
           "P_dB_blue_1": float(res.blue.P_dB[1]),
           "maxrss_bytes": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024}
    if trace_mem:
        out["peak_bytes"] = tracemalloc.get_traced_memory()[1]
    return out


def _run_child(args: list[str]) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    p = subprocess.run([sys.executable, __file__, "--child", *args], capture_output=True,
                       text=True, env=env)
    if p.returncode:
        raise RuntimeError(f"child {args} failed:\n{p.stderr[-3000:]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


# ----------------------------------------------------------------------------- report
def exponent(sizes, values) -> float:
    """Least-squares slope of log(value) vs log(size) (nan with < 2 positive values)."""
    s = np.asarray(sizes, float)
    v = np.asarray(values, float)
    ok = np.isfinite(v) & (v > 0)
    if ok.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(s[ok]), np.log(v[ok]), 1)[0])


def _median_runs(runs: list[dict], key: str) -> dict:
    names = [n for n in STAGES if all(n in r["stages"] for r in runs)]
    return {n: float(np.median([r["stages"][n][key] for r in runs])) for n in names}


def campaign_series(sizes, cache: Path, diagnosis: bool, repeat: int, diag_sizes) -> dict:
    out = {}
    for k in sizes:
        folder = build_campaign(k, cache)
        diag = diagnosis and k in diag_sizes
        times = [_run_child(["analyze", str(folder), str(int(diag)), "0"]) for _ in range(repeat)]
        mems = [_run_child(["analyze", str(folder), str(int(diag)), "1"]) for _ in range(repeat)]
        out[k] = {"size": campaign_size(folder), "diagnosis": diag,
                  "time_s": _median_runs(times, "time_s"),
                  "peak_bytes": _median_runs(mems, "peak_bytes"),
                  "total_s": float(np.median([r["total_s"] for r in times])),
                  "maxrss_bytes": float(np.median([r["maxrss_bytes"] for r in times])),
                  "workers_maxrss_bytes": float(np.median([r.get("workers_maxrss_bytes", 0)
                                                           for r in times])),
                  "maxrss_traced_run_bytes": float(np.median([r["maxrss_bytes"] for r in mems])),
                  "traced_peak_bytes": float(np.median([r["traced_peak_bytes"] for r in mems])),
                  "status": times[0]["status"], "failures": times[0]["failures"]}
        print(f"{k}x: analyze {out[k]['total_s']:.1f} s, maxrss "
              f"{out[k]['maxrss_bytes'] / 2**20:.0f} MiB", flush=True)
    return out


def trace_series(powers, cache: Path, repeat: int) -> dict:
    out = {}
    for m in powers:
        path = cache / f"trace_2^{m}.npz"
        if not path.exists():
            _write_trace(2 ** m, path)
        times = [_run_child(["trace", str(path), "0"]) for _ in range(repeat)]
        mems = [_run_child(["trace", str(path), "1"]) for _ in range(repeat)]
        out[m] = {"file_bytes": path.stat().st_size,
                  "total_s": float(np.median([r["total_s"] for r in times])),
                  "load_s": float(np.median([r["load_s"] for r in times])),
                  "tones_s": float(np.median([r["tones_s"] for r in times])),
                  "peak_bytes": float(np.median([r["peak_bytes"] for r in mems])),
                  "maxrss_bytes": float(np.median([r["maxrss_bytes"] for r in times]))}
        print(f"2^{m}: {out[m]['total_s']:.2f} s, traced peak "
              f"{out[m]['peak_bytes'] / 2**20:.0f} MiB", flush=True)
    return out


def _mib(b) -> str:
    return "-" if b is None or not np.isfinite(b) else f"{b / 2**20:.1f}"


def _sec(t) -> str:
    return "-" if t is None or not np.isfinite(t) else f"{t:.2f}"


def table(camp: dict, traces: dict) -> str:
    lines = []
    if camp:
        sizes = sorted(camp)
        hdr = ("stage".ljust(12) + "".join(f"t({k}x)/s".rjust(11) for k in sizes) + "   exp  "
               + "".join(f"mem({k}x)/MiB".rjust(15) for k in sizes) + "   exp")
        lines += [hdr, "-" * len(hdr)]
        for st in STAGES:
            t = [camp[k]["time_s"].get(st, np.nan) for k in sizes]
            m = [camp[k]["peak_bytes"].get(st, np.nan) for k in sizes]
            if not np.isfinite(t).any():
                continue
            lines.append(st.ljust(12) + "".join(_sec(x).rjust(11) for x in t)
                         + f"{exponent(sizes, t):6.2f}  " + "".join(_mib(x).rjust(15) for x in m)
                         + f"{exponent(sizes, m):6.2f}")
        for key, lab in (("total_s", "analyze"),):
            t = [camp[k][key] for k in sizes]
            m = [camp[k]["maxrss_bytes"] for k in sizes]
            lines.append(lab.ljust(12) + "".join(_sec(x).rjust(11) for x in t)
                         + f"{exponent(sizes, t):6.2f}  " + "".join(_mib(x).rjust(15) for x in m)
                         + f"{exponent(sizes, m):6.2f}   (memory: ru_maxrss)")
        lines.append("rows (calibration_amplitude / phase / spectra / populations / parity): "
                     + "; ".join(f"{k}x " + "/".join(str(camp[k]["size"]["rows"].get(f, 0)) for f in
                                 ("calibration_amplitude.csv", "calibration_phase.csv",
                                  "spectra.csv", "populations.csv", "parity.csv"))
                                 for k in sizes))
    if traces:
        ms = sorted(traces)
        n = [2.0 ** m for m in ms]
        lines.append("")
        lines.append("trace (load_trace + trace_tone_powers): "
                     + "; ".join(f"2^{m}: {traces[m]['total_s']:.2f} s, traced peak "
                                 f"{_mib(traces[m]['peak_bytes'])} MiB, maxrss "
                                 f"{_mib(traces[m]['maxrss_bytes'])} MiB" for m in ms))
        lines.append(f"trace exponents: time {exponent(n, [traces[m]['total_s'] for m in ms]):.2f}, "
                     f"traced peak {exponent(n, [traces[m]['peak_bytes'] for m in ms]):.2f}")
    return "\n".join(lines)


def record_rows(camp: dict, traces: dict) -> list[dict]:
    """The table above as rows of the common record (benchmarks/record.py)."""
    rows = []
    if camp:
        sizes = sorted(camp)
        steps = "analyze per step: median wall time and traced peak above the step's start"
        for st in (*STAGES, "analyze"):
            if st == "analyze":
                t = [camp[k]["total_s"] for k in sizes]
                m = [camp[k]["maxrss_bytes"] for k in sizes]
            else:
                t = [camp[k]["time_s"].get(st, np.nan) for k in sizes]
                m = [camp[k]["peak_bytes"].get(st, np.nan) for k in sizes]
                if not np.isfinite(t).any():
                    continue
            row = {"table": steps, "step": st if st != "analyze" else
                   "analyze (memory: ru_maxrss)"}
            row.update({f"time {k}x [s]": v for k, v in zip(sizes, t)})
            row["time exponent"] = exponent(sizes, t)
            row.update({f"memory {k}x [MiB]": v / 2**20 for k, v in zip(sizes, m)})
            row["memory exponent"] = exponent(sizes, m)
            row["target exponent"] = "<= 1.1"
            rows.append(row)
        for k in sizes:
            r = camp[k]["size"]["rows"]
            rows.append({"table": "campaign sizes", "size": f"{k}x",
                         "diagnosis": camp[k]["diagnosis"],
                         **{f"{f} rows": r.get(f, 0) for f in
                            ("calibration_amplitude.csv", "calibration_phase.csv",
                             "spectra.csv", "populations.csv", "parity.csv")},
                         "bytes on disk [MiB]": camp[k]["size"]["bytes"] / 2**20})
    if traces:
        for m in sorted(traces):
            tr = traces[m]
            rows.append({"table": "trace (load_trace + trace_tone_powers)",
                         "samples": f"2^{m}", "time [s]": tr["total_s"],
                         "load [s]": tr["load_s"], "tones [s]": tr["tones_s"],
                         "traced peak [MiB]": tr["peak_bytes"] / 2**20,
                         "maxrss [MiB]": tr["maxrss_bytes"] / 2**20})
        ms = sorted(traces)
        n = [2.0 ** m for m in ms]
        rows.append({"table": "trace growth exponents (log-log slope against samples)",
                     "time exponent": exponent(n, [traces[m]["total_s"] for m in ms]),
                     "traced peak exponent": exponent(n, [traces[m]["peak_bytes"] for m in ms])})
    return rows


def _main_child(argv):
    kind = argv[0]
    if kind == "analyze":
        res = _child_analyze(argv[1], bool(int(argv[2])), bool(int(argv[3])))
    else:
        res = _child_trace(argv[1], bool(int(argv[2])))
    print(json.dumps(res))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="1,4,16", help="campaign multiples (default 1,4,16)")
    ap.add_argument("--diagnosis", default="",
                    help="sizes at which the diagnosis also runs, e.g. 1,4 (default: none)")
    ap.add_argument("--trace-powers", default="20,22,24", help="log2 trace lengths")
    ap.add_argument("--repeat", type=int, default=1, help="child runs per point (medians)")
    ap.add_argument("--traces-only", action="store_true")
    ap.add_argument("--campaigns-only", action="store_true")
    ap.add_argument("--cache", default="/tmp/dpdfit-scale", help="generated campaigns, traces")
    ap.add_argument("--out", help="write the report JSON here (and the table beside it, .txt)")
    add_json_option(ap)
    a = ap.parse_args(argv)
    cache = Path(a.cache)
    cache.mkdir(parents=True, exist_ok=True)
    sizes = [int(s) for s in a.sizes.split(",") if s]
    diag_sizes = [int(s) for s in a.diagnosis.split(",") if s]
    t0 = time.perf_counter()
    camp = {} if a.traces_only else campaign_series(sizes, cache, bool(diag_sizes), a.repeat,
                                                     diag_sizes)
    traces = {} if a.campaigns_only else trace_series(
        [int(m) for m in a.trace_powers.split(",") if m], cache, a.repeat)
    txt = table(camp, traces)
    print(txt)
    report = {"machine": f"{platform.node()} {platform.processor()} {os.cpu_count()} cores, "
                         f"load average {os.getloadavg()}",
              "python": sys.version.split()[0], "repeat": a.repeat,
              "wall_s": time.perf_counter() - t0, "campaigns": camp, "traces": traces,
              "exponents": {
                  "time": {st: exponent(sorted(camp), [camp[k]["time_s"].get(st, np.nan)
                                                       for k in sorted(camp)]) for st in STAGES},
                  "memory": {st: exponent(sorted(camp), [camp[k]["peak_bytes"].get(st, np.nan)
                                                         for k in sorted(camp)]) for st in STAGES},
              } if camp else {}}
    if a.out:
        Path(a.out).write_text(json.dumps(report, indent=1, default=float) + "\n")
        Path(a.out).with_suffix(".txt").write_text(txt + "\n")
    write_record(a.json, "scale", record_rows(camp, traces), description=summary_line(__doc__),
                 notes=[f"{a.repeat} child run(s) per point (medians); total wall "
                        f"{report['wall_s']:.0f} s."])


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        _main_child(sys.argv[2:])
    else:
        main()
