#!/usr/bin/env python
"""dpdfit's gate engine against QuTiP's mesolve on the same master equations; the null model.

    python benchmarks/engine_vs_qutip.py [--campaign DIR] [--repeats 7] [--tight-repeats 3]
                                         [--all-runs] [--null-campaign DIR ...]
                                         [--null-repeats 3] [--json PATH]

The problems are the diagnosis's own: the master equations its null model integrates on
the campaign ``--campaign`` (every call of :func:`dpdfit.models.gate_sim.setting_branches`
while the diagnosis's ``Problem`` is built, captured in this process with one worker),
and the default gate (Cardioid(1,2), ``nbar = 0.1``, the lab's ``T2`` and heating, the
engine's default tolerances).  Of the null model's runs four are compared: the two-ion
branch with the smallest and with the largest Fock space, the two-ion branch with the most
output times (a time scan), and the one-ion branch with the largest Fock space.

QuTiP is given the same problem: the Hamiltonian ``K(tau) a^dag + K(tau)^dag a`` in the
engine's time ``tau = t xi0`` as a ``QobjEvo`` whose coefficients are the engine's
``beta(tau)``, ``gamma(tau)`` (:class:`dpdfit.models.gate_sim.drive.Drive`), the collapse
operators ``sqrt(gamma/2) Z_j``, ``sqrt(gamma_c/2) (Z_1 + Z_2)``, ``sqrt(heat) a``,
``sqrt(heat) a^dag``, the same thermal initial state and Fock cutoff, the same output
times and the same ``rtol``/``atol``; QuTiP's default method (``adams``) and ``dop853``
(the engine's own method) are both run.  Per case:

* the agreement at tight tolerance (``rtol = 1e-12``, ``atol = 1e-14``): the largest
  ``|rho_dpdfit - rho_qutip|`` over the spin density matrices at every output time, and
  the difference of the Bell fidelity (best Bell phase) at the gate time;
* at the case's own tolerances (the diagnosis's ``ENGINE_PRECISION`` for the null
  model's runs): the median wall seconds of each over ``--repeats`` interleaved runs, the
  ratio qutip / dpdfit, and each one's error against the tight dpdfit solution;
* with ``--all-runs``: every captured integration once with each, summed.

Finally the null model's seconds: ``dpdfit diagnose DIR --json`` in a fresh process (as
``benchmarks/diagnose_speed.py`` runs it) on each ``--null-campaign`` (default: the
campaign above), its ``timing_seconds["null model"]``, median of ``--null-repeats`` runs
(0: skipped).  BLAS is single-threaded throughout, as in the diagnosis; the 1-minute load
average is printed beside every timing.
"""

from __future__ import annotations

import argparse
import cmath
import functools
import inspect
import os
import statistics
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import qutip
from threadpoolctl import threadpool_limits

from dpdfit.analyses.diagnosis.effects import EFFECTS, default_effects
from dpdfit.analyses.diagnosis.model.residuals import Problem
from dpdfit.analyses.diagnosis.observables.campaign import load_campaign
from dpdfit.models import gate_sim
from record import ROOT, add_json_option, summary_line, write_record

TIGHT = {"rtol": 1e-12, "atol": 1e-14}
QUTIP_METHODS = ("adams", "dop853")
#: the default gate: Cardioid(1,2) at xi0 = 3.4 kHz (T = 294 us), eta Omega0 calibrated
CARDIOID_N = np.array([1, 2])
CARDIOID_R = np.array([1.0, -1.0]) / np.sqrt(1.5)
CARDIOID_XI0 = 3.4e3


def load() -> float:
    return os.getloadavg()[0]


def shown(folder: Path) -> str:
    """A campaign folder as the record shows it: relative to the repository if inside."""
    try:
        return str(folder.relative_to(ROOT))
    except ValueError:
        return str(folder)


# --------------------------------------------------------------------------- problems
@dataclass(frozen=True)
class Integration:
    """One master-equation integration of the engine, as
    :func:`~dpdfit.models.gate_sim.evolve_lindblad` takes it."""

    b: np.ndarray
    c: np.ndarray
    n: np.ndarray
    eta_Omega0: float
    xi0: float
    times: np.ndarray
    nbar: float
    T2: float
    ndot: float
    T2_corr: float
    n_ions: int
    initial: int
    rtol: float
    atol: float
    fock_tol: float | None

    def kwargs(self, **over) -> dict:
        kw = {"T2": self.T2, "ndot": self.ndot, "T2_corr": self.T2_corr,
              "n_ions": self.n_ions, "initial": self.initial, "rtol": self.rtol,
              "atol": self.atol, "fock_tol": self.fock_tol}
        kw.update(over)
        return kw

    def start_size(self):
        """The engine's Fock space for this run (:func:`~dpdfit.models.gate_sim.engine_size`)."""
        return gate_sim.engine_size(self.b, self.c, self.n, self.eta_Omega0, self.xi0,
                                    float(self.times.max()), self.nbar, n_ions=self.n_ions,
                                    fock_tol=self.fock_tol)

    def thermal(self) -> np.ndarray:
        """The engine's thermal weights of the initial state."""
        return (gate_sim.thermal_weights(self.nbar) if self.fock_tol is None
                else gate_sim.thermal_weights(self.nbar, self.fock_tol))


#: preparation branches of setting_branches: name -> (ions, initial spin state)
BRANCHES = {"2": (2, 0), "1": (1, 0), "2_01": (2, 1), "1_1": (1, 1)}


def integrations_of(args, kw) -> list[Integration]:
    """The master equations one call of :func:`~dpdfit.models.gate_sim.setting_branches`
    integrates, one per preparation branch (as that function maps its arguments)."""
    bound = inspect.signature(gate_sim.setting_branches).bind(*args, **kw)
    bound.apply_defaults()
    a = bound.arguments
    eO = float(a["eta_Omega0"]) * 10 ** (float(a["power_error_db"]) / 20)
    xi0 = float(a["xi0"])
    scan = (np.zeros(0) if a["scan_times"] is None
            else np.atleast_1d(np.asarray(a["scan_times"], dtype=float)))
    times = np.concatenate([[1.0 / xi0], scan])
    names = a["branches"]
    if names is None:
        names = ["2"] + (["1"] if a["spectator"] else []) + (["2_01"] if a["flip"] else []) \
            + (["1_1"] if a["spectator"] and a["flip"] else [])
    return [Integration(np.asarray(a["b"], dtype=complex), np.asarray(a["c"], dtype=complex),
                        np.asarray(a["n"]), eO, xi0, times, float(a["nbar"]), float(a["T2"]),
                        float(a["ndot"]), float(a["T2_corr"]), *BRANCHES[name],
                        float(a["rtol"]), float(a["atol"]),
                        None if a["fock_tol"] is None else float(a["fock_tol"]))
            for name in names]


def capture_null_model(folder: Path) -> tuple[list[Integration], float]:
    """Every integration the diagnosis's null model asks of the engine on ``folder`` (its
    ``Problem`` built as :func:`dpdfit.analyses.diagnosis.diagnose.diagnose` builds it,
    one worker so that the calls are seen here), and the seconds that took."""
    seen = []
    engine = gate_sim.setting_branches

    def recording(*args, **kw):
        seen.append((args, kw))
        return engine(*args, **kw)

    workers = os.environ.get("DPDFIT_WORKERS")
    os.environ["DPDFIT_WORKERS"] = "1"
    gate_sim.setting_branches = recording
    try:
        with threadpool_limits(limits=1, user_api="blas"):
            t0 = time.perf_counter()
            camp = load_campaign(folder)
            effects = tuple(e for e in default_effects()
                            if camp.gates is not None or EFFECTS[e].side == "tones")
            Problem(camp, with_gates=True, effects=effects)
            seconds = time.perf_counter() - t0
    finally:
        gate_sim.setting_branches = engine
        if workers is None:
            del os.environ["DPDFIT_WORKERS"]
        else:
            os.environ["DPDFIT_WORKERS"] = workers
    return [i for args, kw in seen for i in integrations_of(args, kw)], seconds


def default_gate() -> Integration:
    """The default gate at the engine's default tolerances and Fock rule."""
    eO = CARDIOID_XI0 / gate_sim.calibrate_xi0(CARDIOID_R, CARDIOID_R, CARDIOID_N, 1.0)
    r = CARDIOID_R.astype(complex)
    return Integration(r, r, CARDIOID_N, eO, CARDIOID_XI0, np.array([1.0 / CARDIOID_XI0]),
                       0.1, gate_sim.T2_S, gate_sim.NDOT, np.inf, 2, 0, 1e-9, 1e-11, None)


def pick_cases(runs: list[Integration]) -> list[tuple[str, Integration]]:
    """The null model's runs compared one by one (module doc), each once."""
    sized = [(r, r.start_size().n_fock) for r in runs]
    two = [s for s in sized if s[0].n_ions == 2]
    one = [s for s in sized if s[0].n_ions == 1]
    wanted = []
    if two:
        wanted += [("null model: two ions, smallest Fock space", min(two, key=lambda s: s[1])),
                   ("null model: two ions, largest Fock space", max(two, key=lambda s: s[1])),
                   ("null model: two ions, most output times",
                    max(two, key=lambda s: (s[0].times.size, s[1])))]
    if one:
        wanted.append(("null model: one ion", max(one, key=lambda s: s[1])))
    out, ids = [], set()
    for label, (run, _) in wanted:
        if id(run) not in ids:
            ids.add(id(run))
            out.append((label, run))
    return out


# --------------------------------------------------------------------------- QuTiP
class QutipEngine:
    """The engine's master equation as QuTiP objects, its spin states from ``mesolve``.

    The operators that depend only on the Fock cutoff are made once per cutoff (as a
    user of QuTiP would keep them); what a run changes (the drive's coefficients, the
    rates, the initial state) is made in :meth:`solve`, inside the timing.
    """

    def __init__(self):
        self._ops = {}

    def _operators(self, n_ions: int, N: int) -> dict:
        key = (n_ions, N)
        if key not in self._ops:
            sp = qutip.Qobj(np.array([[0, 0], [1, 0]], dtype=complex))   # sigma+ = |1><0|
            i2 = qutip.qeye(2)
            if n_ions == 1:
                Sp, Z = sp, [qutip.sigmaz()]
            else:
                Sp = qutip.tensor(sp, i2) + qutip.tensor(i2, sp)
                Z = [qutip.tensor(qutip.sigmaz(), i2), qutip.tensor(i2, qutip.sigmaz())]
            a, iN = qutip.destroy(N), qutip.qeye(N)
            ispin = qutip.qeye([2] * n_ions)
            A1 = 1j * qutip.tensor(Sp, a.dag())          # beta(tau) i S+ a^dag
            A2 = -1j * qutip.tensor(Sp.dag(), a.dag())   # gamma(tau) (-i) S- a^dag
            self._ops[key] = {
                "A1": A1, "A2": A2, "A1d": A1.dag(), "A2d": A2.dag(),
                "Z": [qutip.tensor(z, iN) for z in Z],
                "Zsum": qutip.tensor(sum(Z[1:], Z[0]), iN),
                "a": qutip.tensor(ispin, a), "ad": qutip.tensor(ispin, a.dag())}
        return self._ops[key]

    def solve(self, run: Integration, N: int, rtol: float, atol: float,
              method: str) -> np.ndarray:
        """Spin density matrices at ``run.times`` (shape ``(times, d, d)``)."""
        ops = self._operators(run.n_ions, N)
        # K(tau)/xi0 as dpdfit.models.gate_sim.drive.Drive makes it
        scale = 0.5 * run.eta_Omega0 / run.xi0
        bb = (scale * run.b).tolist()
        cc = (scale * np.conj(run.c)).tolist()
        w = (-2j * np.pi * np.asarray(run.n, dtype=float)).tolist()

        # plain Python sums over the few tones: cheaper per call than numpy's overhead
        def beta(t):
            return sum(x * cmath.exp(wk * t) for x, wk in zip(bb, w))

        def gam(t):
            return sum(x * cmath.exp(wk * t) for x, wk in zip(cc, w))

        H = qutip.QobjEvo([[ops["A1"], beta], [ops["A2"], gam],
                           [ops["A1d"], lambda t: beta(t).conjugate()],
                           [ops["A2d"], lambda t: gam(t).conjugate()]])
        gamma = 0.0 if np.isinf(run.T2) else 1.0 / (run.T2 * run.xi0)
        gamma_c = 0.0 if np.isinf(run.T2_corr) else 1.0 / (run.T2_corr * run.xi0)
        heat = run.ndot / run.xi0
        c_ops = [np.sqrt(gamma / 2) * z for z in ops["Z"]] if gamma else []
        if gamma_c:
            c_ops.append(np.sqrt(gamma_c / 2) * ops["Zsum"])
        if heat:
            c_ops += [np.sqrt(heat) * ops["a"], np.sqrt(heat) * ops["ad"]]
        d = 2 ** run.n_ions
        p = np.zeros(N)
        w_th = run.thermal()
        p[:w_th.size] = w_th
        spin = np.zeros((d, d))
        spin[run.initial, run.initial] = 1.0
        rho0 = qutip.Qobj(np.kron(spin, np.diag(p)), dims=[[2] * run.n_ions + [N]] * 2)
        tau = np.asarray(run.times, dtype=float) * run.xi0
        order = np.argsort(tau, kind="stable")
        tlist = np.concatenate([[0.0], tau[order]])
        res = qutip.mesolve(H, rho0, tlist, c_ops,
                            options={"method": method, "rtol": rtol, "atol": atol,
                                     "nsteps": 10 ** 7, "progress_bar": False,
                                     "store_states": True})
        out = np.empty((tau.size, d, d), dtype=complex)
        for k, state in zip(order, res.states[1:]):
            out[k] = np.einsum("ikjk->ij", state.full().reshape(d, N, d, N))
        return 0.5 * (out + np.conj(np.swapaxes(out, -1, -2)))   # as the engine returns


def dpdfit_solve(run: Integration, N: int, rtol: float, atol: float) -> np.ndarray:
    """The engine's spin density matrices at ``run.times`` on ``N`` Fock levels."""
    return np.asarray(gate_sim.evolve_lindblad(run.b, run.c, run.n, run.eta_Omega0, run.xi0,
                                               run.times, run.nbar,
                                               **run.kwargs(n_fock=N, rtol=rtol, atol=atol)))


def bell(rho: np.ndarray) -> float:
    """Bell fidelity (best phase) of the two-ion state at the gate time."""
    return gate_sim.bell_fidelity_max(rho[0])


# --------------------------------------------------------------------------- measurement
def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def compare(label: str, run: Integration, qt: QutipEngine, repeats: int,
            tight_repeats: int) -> dict:
    """Agreement at tight tolerance and timings at the run's own (module doc)."""
    _, info = gate_sim.evolve_lindblad(run.b, run.c, run.n, run.eta_Omega0, run.xi0,
                                       run.times, run.nbar, return_info=True, **run.kwargs())
    N = int(info["n_fock"])                       # the engine's cutoff, given to both

    def engines(rtol, atol):
        fns = {"dpdfit": lambda: dpdfit_solve(run, N, rtol, atol)}
        for m in QUTIP_METHODS:
            fns[f"qutip {m}"] = (lambda m=m: qt.solve(run, N, rtol, atol, m))
        return fns

    def measure(fns, reps):
        # interleaved, so that a change of the machine's load falls on every engine alike
        secs = {k: [] for k in fns}
        rho = {}
        loads = []
        for k, f in fns.items():                  # warm-up: first calls, operators made
            rho[k] = f()
        for _ in range(reps):
            loads.append(load())
            for k, f in fns.items():
                rho[k], s = timed(f)
                secs[k].append(s)
        return rho, {k: statistics.median(v) for k, v in secs.items()}, statistics.median(loads)

    with threadpool_limits(limits=1, user_api="blas"):
        ref, t_tight, load_tight = measure(engines(**TIGHT), tight_repeats)
        got, t_case, load_case = measure(engines(run.rtol, run.atol), repeats)
    row = {"table": "cases", "case": label, "ions": run.n_ions, "n_fock": N,
           "output times": int(run.times.size), "tones": int(run.b.size),
           "rtol": run.rtol, "atol": run.atol}
    for m in QUTIP_METHODS:
        row[f"tight: drho qutip {m}"] = float(np.max(np.abs(ref["dpdfit"]
                                                                 - ref[f"qutip {m}"])))
        if run.n_ions == 2:
            row[f"tight: dF_Bell qutip {m}"] = abs(bell(ref["dpdfit"])
                                                     - bell(ref[f"qutip {m}"]))
    row["tight: dpdfit [s]"] = t_tight["dpdfit"]
    for m in QUTIP_METHODS:
        row[f"tight: qutip {m} [s]"] = t_tight[f"qutip {m}"]
        row[f"tight: ratio qutip {m} / dpdfit"] = t_tight[f"qutip {m}"] / t_tight["dpdfit"]
    row["dpdfit [s]"] = t_case["dpdfit"]
    for m in QUTIP_METHODS:
        row[f"qutip {m} [s]"] = t_case[f"qutip {m}"]
        row[f"ratio qutip {m} / dpdfit"] = t_case[f"qutip {m}"] / t_case["dpdfit"]
    for k in got:
        row[f"error {k}"] = float(np.max(np.abs(got[k] - ref["dpdfit"])))
    row["load, 1 min (tight)"] = load_tight
    row["load, 1 min"] = load_case
    return row


def all_runs(runs: list[Integration], qt: QutipEngine) -> dict:
    """Every captured integration once with each engine, at its own tolerances."""
    sums = {"dpdfit": 0.0, **{f"qutip {m}": 0.0 for m in QUTIP_METHODS}}
    worst = {f"qutip {m}": 0.0 for m in QUTIP_METHODS}
    load0 = load()
    with threadpool_limits(limits=1, user_api="blas"):
        # warm-up of both on the first run (imports, first-call costs)
        N0 = runs[0].start_size().n_fock
        dpdfit_solve(runs[0], N0, runs[0].rtol, runs[0].atol)
        for m in QUTIP_METHODS:
            qt.solve(runs[0], N0, runs[0].rtol, runs[0].atol, m)
        for run in runs:
            N = run.start_size().n_fock
            rho, s = timed(functools.partial(dpdfit_solve, run, N, run.rtol, run.atol))
            sums["dpdfit"] += s
            for m in QUTIP_METHODS:
                rq, s = timed(functools.partial(qt.solve, run, N, run.rtol, run.atol, m))
                sums[f"qutip {m}"] += s
                worst[f"qutip {m}"] = max(worst[f"qutip {m}"], float(np.max(np.abs(rq - rho))))
    row = {"table": "every integration of the null model, once each", "integrations": len(runs),
           "two-ion": sum(r.n_ions == 2 for r in runs), "one-ion": sum(r.n_ions == 1 for r in runs),
           "dpdfit [s]": sums["dpdfit"]}
    for m in QUTIP_METHODS:
        row[f"qutip {m} [s]"] = sums[f"qutip {m}"]
        row[f"ratio qutip {m} / dpdfit"] = sums[f"qutip {m}"] / sums["dpdfit"]
        row[f"drho qutip {m}"] = worst[f"qutip {m}"]
    row["load, 1 min (start, end)"] = [load0, load()]
    return row


def null_model_seconds(folder: Path, repeats: int) -> dict:
    """The diagnosis's ``null model`` stage, ``dpdfit diagnose`` in a fresh process."""
    from diagnose_speed import run_once  # the same child process as that benchmark

    runs = []
    for _ in range(repeats):
        r = run_once(folder)
        runs.append(r)
        print(f"  dpdfit diagnose: null model {r['stages'].get('null model', float('nan')):.2f} s"
              f"  (wall {r['wall']:.1f} s, load {r['load']:.2f}, verdict {r['verdict']})",
              flush=True)
    stage = [r["stages"].get("null model", float("nan")) for r in runs]
    return {"table": "null model stage of dpdfit diagnose", "campaign": shown(folder),
            "runs": len(runs), "null model, median [s]": statistics.median(stage),
            "null model, min [s]": min(stage), "null model, max [s]": max(stage),
            "diagnose wall, median [s]": statistics.median(r["wall"] for r in runs),
            "verdict": runs[0]["verdict"],
            "load, 1 min, median": statistics.median(r["load"] for r in runs)}


# --------------------------------------------------------------------------- main
def _print_case(row: dict) -> None:
    print(f"{row['case']}: {row['ions']} ion(s), n_fock {row['n_fock']}, "
          f"{row['output times']} output times, {row['tones']} tones")
    for m in QUTIP_METHODS:
        f = row.get(f"tight: dF_Bell qutip {m}")
        print(f"  tight {TIGHT['rtol']:.0e}/{TIGHT['atol']:.0e}: qutip {m:6s} max |drho| "
              f"{row[f'tight: drho qutip {m}']:.1e}"
              + ("" if f is None else f", |dF_Bell| {f:.1e}")
              + f";  {row[f'tight: qutip {m} [s]']:.3f} s vs dpdfit "
                f"{row['tight: dpdfit [s]']:.3f} s = "
                f"{row[f'tight: ratio qutip {m} / dpdfit']:.2f}x")
    print(f"  at rtol {row['rtol']:.0e}, atol {row['atol']:.0e} (load "
          f"{row['load, 1 min']:.2f}): dpdfit {row['dpdfit [s]']:.3f} s "
          f"(error {row['error dpdfit']:.1e})")
    for m in QUTIP_METHODS:
        print(f"    qutip {m:6s} {row[f'qutip {m} [s]']:.3f} s = "
              f"{row[f'ratio qutip {m} / dpdfit']:.2f}x dpdfit (error "
              f"{row[f'error qutip {m}']:.1e})")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=summary_line(__doc__))
    parser.add_argument("--campaign", type=Path, default=ROOT / "datasets" / "synthetic_campaign",
                        help="campaign whose null model gives the problems (default: "
                             "datasets/synthetic_campaign)")
    parser.add_argument("--repeats", type=int, default=7,
                        help="timed runs per engine at the case's tolerances (7)")
    parser.add_argument("--tight-repeats", type=int, default=3,
                        help="timed runs per engine at tight tolerance (3)")
    parser.add_argument("--all-runs", action="store_true",
                        help="also integrate every captured run once with each engine")
    parser.add_argument("--null-campaign", type=Path, action="append", default=None,
                        help="campaign of the null model's seconds (repeatable; default: "
                             "--campaign)")
    parser.add_argument("--null-repeats", type=int, default=3,
                        help="runs of dpdfit diagnose for the null model's seconds (3; 0: none)")
    add_json_option(parser)
    args = parser.parse_args(argv)
    folder = args.campaign.resolve()
    print(f"qutip {qutip.__version__}, numpy {np.__version__}; campaign {shown(folder)}; "
          f"load {load():.2f}", flush=True)
    runs, captured_s = capture_null_model(folder)
    two = [r for r in runs if r.n_ions == 2]
    sizes = sorted({r.start_size().n_fock for r in two})
    print(f"null model: {len(runs)} integrations ({len(two)} two-ion, n_fock "
          f"{sizes[0] if sizes else '-'}-{sizes[-1] if sizes else '-'}; "
          f"{len(runs) - len(two)} one-ion), captured in {captured_s:.1f} s with one worker "
          f"(load {load():.2f})", flush=True)
    rows = [{"table": "the null model's integrations", "campaign": shown(folder),
             "integrations": len(runs), "two-ion": len(two), "one-ion": len(runs) - len(two),
             "two-ion n_fock, min": sizes[0] if sizes else None,
             "two-ion n_fock, max": sizes[-1] if sizes else None,
             "problem built with one worker [s]": captured_s}]
    cases = pick_cases(runs) + [("default gate: Cardioid(1,2), nbar 0.1", default_gate())]
    qt = QutipEngine()
    for label, run in cases:
        row = compare(label, run, qt, args.repeats, args.tight_repeats)
        _print_case(row)
        rows.append(row)
    if args.all_runs and runs:
        row = all_runs(runs, qt)
        rows.append(row)
        print(f"every null-model integration once ({row['integrations']}): dpdfit "
              f"{row['dpdfit [s]']:.2f} s; " + "; ".join(
                  f"qutip {m} {row[f'qutip {m} [s]']:.2f} s = "
                  f"{row[f'ratio qutip {m} / dpdfit']:.2f}x (max |drho| "
                  f"{row[f'drho qutip {m}']:.1e})" for m in QUTIP_METHODS)
              + f"; load {row['load, 1 min (start, end)']}", flush=True)
    null_folders = (args.null_campaign or [folder]) if args.null_repeats > 0 else []
    for null_folder in null_folders:
        row = null_model_seconds(null_folder.resolve(), args.null_repeats)
        rows.append(row)
        print(f"null model stage on {row['campaign']}: median "
              f"{row['null model, median [s]']:.2f} s ({row['runs']} runs, load "
              f"{row['load, 1 min, median']:.2f})", flush=True)
    write_record(args.json, "engine_vs_qutip", rows, description=summary_line(__doc__),
                 notes=[f"qutip {qutip.__version__}, numpy {np.__version__}.",
                        ("QuTiP gets the engine's Hamiltonian (QobjEvo with the drive's "
                         "coefficient functions), collapse operators, thermal initial state, "
                         "Fock cutoff, output times and rtol/atol; 'adams' is mesolve's "
                         "default method, 'dop853' the engine's.  QuTiP's seconds include "
                         "making the QobjEvo and mesolve's Liouvillian; the operators fixed "
                         "by the Fock cutoff are made once.  QuTiP's coefficients are Python "
                         "functions (its compiled string coefficients need Cython)."),
                        ("drho: max |rho_dpdfit - rho_qutip| over the spin density "
                         "matrices' elements at every output time; dF_Bell: the difference "
                         "of the Bell fidelity (best phase) at the gate time."),
                        ("error: max |rho - rho_ref| over the output times, rho_ref the "
                         f"engine at rtol {TIGHT['rtol']:g}, atol {TIGHT['atol']:g}."),
                        ("Timings are medians of interleaved runs, BLAS single-threaded; on a "
                         "shared machine they are upper bounds (load beside each).")])


if __name__ == "__main__":
    main()
