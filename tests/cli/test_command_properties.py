"""Property-based tests of the command line.

``main(argv)`` with a generated mutation of a valid input file (see
:mod:`tests.helpers.prop_mutations`) and generated option values (floats incl. nan, inf,
negative and huge; integers; junk text) must either exit 0 with finite outputs
(no NaN or inf in a written CSV or JSON, nor as a word in the printed report)
or exit 2 with exactly one stderr line ``dpdfit: error: ...`` naming an input
file or an option, and no traceback; the input files are never modified.

Only light options are generated (small grids, few draws); ``analyze`` and
``diagnose`` are left to their own tests.  Default profile ``ci``; the larger
run is ``HYPOTHESIS_PROFILE=thorough python -m pytest tests/cli/test_command_properties.py``.
"""

import contextlib
import io
import json
import re
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest
import pandas as pd
from hypothesis import example, given
from hypothesis import strategies as st
from tests.helpers.prop_mutations import (TALLY, Traceback, base_texts, csv_mutations,
                                          json_mutations, mutate_csv, mutate_json, number_texts,
                                          _fail)

from dpdfit.cli.main import main

_NONFINITE = re.compile(r"(?<![\w.])-?(nan|inf)(?![\w])", re.IGNORECASE)


def valid(key) -> bytes:
    return base_texts()[key].encode()


def json_edit(key, *ops) -> bytes:
    return mutate_json(json.loads(base_texts()[key]), list(ops))


def maybe_csv(key):
    """The valid file (one time in four) or a mutation of it, as bytes."""
    return st.one_of(st.just(None), csv_mutations(), csv_mutations(), csv_mutations()).map(
        lambda ops: mutate_csv(base_texts()[key], ops or []))


def maybe_json(key):
    return st.one_of(st.just(None), json_mutations(), json_mutations()).map(
        lambda ops: base_texts()[key].encode() if ops is None
        else mutate_json(json.loads(base_texts()[key]), ops))


def opt(name, values=None):
    """``[]`` or ``[name, value]`` for an optional option."""
    values = number_texts() if values is None else values
    return st.one_of(st.just([]), values.map(lambda v: [name, v]))


def small_ints(lo=-3, hi=40):
    return st.one_of(st.integers(lo, hi).map(str), st.sampled_from(["abc", "", "1.5", "nan"]))


def run_cli(command, files: dict, argv_of, outputs=()):
    """Write ``files`` (name -> bytes) into a fresh folder, run ``main(argv_of(folder))``
    and check the contract; the outcome is counted in TALLY[command]."""
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        for name, data in files.items():
            (d / name).write_bytes(data)
        argv = [str(a) for a in argv_of(d)]
        out, err = io.StringIO(), io.StringIO()
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), \
                    warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")          # as a user sees them: on stderr
                code = main(argv)
        except Exception as exc:  # noqa: BLE001 - the failure being looked for
            return _fail(command, f"{type(exc).__name__}: {exc} (argv {argv})", exc)
        err.write("".join(warnings.formatwarning(w.message, w.category, w.filename, w.lineno)
                          for w in caught))
        for name, data in files.items():
            if (d / name).read_bytes() != data:
                raise Traceback(f"{command} modified its input {name}")
        problem = _check(code, out.getvalue(), err.getvalue(), argv,
                         [d / o for o in outputs], [str(d / n) for n in files])
        if problem:
            return _fail(command, f"{problem} (argv {argv})")
        TALLY[command]["ok" if code == 0 else "clean"] += 1
        return code


def _check(code, out, err, argv, outputs, inputs):
    if code == 2:
        lines = err.strip().splitlines()
        if len(lines) != 1 or not lines[0].startswith("dpdfit: error:"):
            return f"exit 2 without exactly one 'dpdfit: error:' line: {err!r}"
        if not (any(p in lines[0] for p in inputs) or "--" in lines[0]
                or "argument" in lines[0]):
            return f"error names neither an input file nor an option: {lines[0]!r}"
        return None
    if code != 0:
        return f"exit status {code}: {err!r}"
    if "Traceback" in err:
        return f"traceback on stderr: {err!r}"
    if _NONFINITE.search(out):
        return f"non-finite number in the report: {out!r}"
    for p in outputs:
        if not p.exists():
            return f"exit 0 but {p.name} not written"
        bad = _nonfinite_output(p)
        if bad:
            return f"{p.name}: {bad}"
    return None


#: output -> the columns that hold its results (diagnostics that do not apply are empty)
_RESULT_COLUMNS = {"g.csv": ["A", "dpd", "F_pop", "F_pop_err", "F_par", "F_par_err", "F",
                             "F_err", "contrast", "phi0", "n_scans", "shots"]}


def _nonfinite_output(p: Path):
    if p.suffix == ".json":
        def refuse(c):
            raise ValueError(c)
        try:
            json.loads(p.read_text(), parse_constant=refuse)
        except ValueError as exc:
            return f"non-finite JSON value {exc}"
        return None
    df = pd.read_csv(p, comment="#")
    if len(df) == 0:
        return "empty table"
    cols = _RESULT_COLUMNS.get(p.name, list(df.select_dtypes("number").columns))
    num = df[[c for c in cols if c in df.columns]].to_numpy(dtype=float)
    if not np.isfinite(num).all():
        return "non-finite value in the table"
    return None


# ----------------------------------------------------------------------------- commands


@given(amp=maybe_csv("amplitude"), phase=st.one_of(st.none(), maybe_csv("phase")),
       order=opt("--order", small_ints(-1, 12)), phase_order=opt("--phase-order", small_ints(-1, 8)),
       lo=opt("--phase-min-A"), hi=opt("--phase-max-A"),
       scan=st.sampled_from(["none", "3:5", "5:3", "0:2", "x"]))
@example(amp=valid("amplitude"), phase=None, order=[], phase_order=[], lo=[], hi=[],
         scan="0:2")                                   # 'no powers given': no option named
@example(amp=valid("amplitude"), phase=valid("phase"), order=[], phase_order=[],
         lo=["--phase-min-A", "1"], hi=[], scan="none")  # 'phase fit window': no option named
def test_calibrate(amp, phase, order, phase_order, lo, hi, scan):
    files = {"amp.csv": amp, **({} if phase is None else {"phase.csv": phase})}
    run_cli("calibrate", files, lambda d: [
        "calibrate", "--amplitude", d / "amp.csv",
        *(["--phase", d / "phase.csv"] if phase is not None else []),
        *order, *phase_order, *lo, *hi, "--order-scan", scan, "-o", d / "cal.json"],
        ["cal.json"])


_GRIDS = st.one_of(st.sampled_from(["0.2:1:5", "0:1:4", "1:0.2:4", "0.2:1:0", "0.5:0.5:4",
                                    "a:b:c", "0.2:1", "", "nan:1:5", "0.2:2:5", "-1:1:5"]),
                   st.tuples(number_texts(), number_texts(), small_ints(-2, 8)).map(":".join))


@given(cal=maybe_json("calibration"), grid=_GRIDS, nbar=opt("--nbar"), xi0=opt("--xi0"),
       nu=opt("--nu"), eta=opt("--eta-ref"), anchor=opt("--anchor-A"), am_only=st.booleans())
@example(cal=valid("calibration"), grid="0.2:1:5", nbar=[], xi0=[], nu=["--nu", "1e308"],
         eta=[], anchor=[], am_only=False)             # OverflowError
@example(cal=valid("calibration"), grid="0.2:1:5", nbar=[], xi0=[], nu=["--nu", "1"],
         eta=[], anchor=[], am_only=False)             # 'nu/xi0 ... not a ratio': no option named
def test_sweep(cal, grid, nbar, xi0, nu, eta, anchor, am_only):
    run_cli("sweep", {"cal.json": cal}, lambda d: [
        "sweep", d / "cal.json", "--amplitudes", grid, *nbar, *xi0, *nu, *eta, *anchor,
        *(["--am-only"] if am_only else []), "-o", d / "s.csv"], ["s.csv"])


@given(cal=maybe_json("calibration"), points=opt("--points", small_ints(-3, 3000)),
       strict=st.booleans())
@example(cal=json_edit("calibration", ("set", 4, float("inf"))), points=[], strict=False)
@example(cal=json_edit("calibration", ("set", 4, 0)), points=[], strict=False)
@example(cal=json_edit("calibration", ("set", 4, 1e308)), points=[], strict=False)
@example(cal=json_edit("calibration", ("set", 7, 10**400)), points=[], strict=False)
@example(cal=json_edit("calibration", ("set", 670833, 1e308)), points=[], strict=False)
def test_lut(cal, points, strict):
    run_cli("lut", {"cal.json": cal}, lambda d: [
        "lut", d / "cal.json", *points, *(["--strict"] if strict else []), "-o", d / "l.csv"],
        ["l.csv", "l.json"])


_POWERS = st.lists(st.tuples(small_ints(-3, 6), number_texts()).map(":".join),
                   min_size=0, max_size=5).map(",".join)


@given(powers=st.one_of(st.just("0:-40,1:0,2:0,3:-30"), _POWERS), nbar=opt("--nbar"),
       formula=st.sampled_from(["exact", "paper"]))
@example(powers="1:-3081,2:0.0", nbar=[], formula="exact")     # F_est = nan printed, exit 0
def test_estimate(powers, nbar, formula):
    run_cli("estimate", {}, lambda d: ["estimate", "--powers-db", powers, *nbar,
                                       "--formula", formula])


@given(which=st.sampled_from(["populations", "parity", "gate_rates"]), ops=csv_mutations(),
       interval=st.sampled_from(["wilson", "clopper-pearson"]), rates=st.booleans())
def test_fidelity(which, ops, interval, rates):
    files = {k: base_texts()[k].encode() for k in ("populations", "parity", "gate_rates")}
    files[which] = mutate_csv(base_texts()[which], ops)
    run_cli("fidelity", files, lambda d: [
        "fidelity", "--populations", d / "populations", "--parity", d / "parity",
        "--interval", interval,
        *(["--gate-rates", d / "gate_rates"] if rates or which == "gate_rates" else []),
        "-o", d / "g.csv"], ["g.csv"])


@given(sweep=maybe_csv("sweep"), a_corr=opt("--A-corr"), as_json=st.booleans())
@example(sweep=mutate_csv(base_texts()["sweep"], [("one_row", 0, 0, None)]), a_corr=[],
         as_json=False)                                # 'sweep table has 0 amplitudes': no file
def test_thresholds(sweep, a_corr, as_json):
    run_cli("thresholds", {"sweep.csv": sweep}, lambda d: [
        "thresholds", d / "sweep.csv", *a_corr, *(["--json"] if as_json else [])])


@given(which=st.sampled_from(["gate", "sweep"]), ops=st.one_of(st.just([]), csv_mutations()),
       sigma=opt("--sigma-db"))
@example(which="gate", ops=[], sigma=["--sigma-db", "1e308"])     # LinAlgError
@example(which="gate", ops=[("one_row", 0, 0, None)], sigma=[])   # no file named
def test_align(which, ops, sigma):
    files = {k: base_texts()[k].encode() for k in ("gate", "sweep")}
    files[which] = mutate_csv(base_texts()[which], ops)
    run_cli("align", files, lambda d: ["align", "--gate", d / "gate", "--sweep", d / "sweep",
                                       *sigma])


@given(runs=maybe_csv("runs"), kind=opt("--kind", st.sampled_from(["amplitude", "phase"])),
       order=opt("--order", small_ints(-1, 9)), a_min=opt("--phase-min-A"))
@example(runs=valid("runs"), kind=[], order=["--order", "1"], a_min=[])  # nan, inf reported
@example(runs=valid("runs"), kind=["--kind", "phase"], order=[],
         a_min=["--phase-min-A", "1"])                  # 'phase fit window': no option named
@example(runs=mutate_csv(base_texts()["runs"], [("cell", 1, 63, "1e22")]), kind=[], order=[],
         a_min=[])                                     # LinAlgError in the drift test
@example(runs=mutate_csv(base_texts()["runs"], [("cell", 1, 63, "1e308")]), kind=[], order=[],
         a_min=[])                                     # ValueError from least_squares
@example(runs=b"".join(ln for ln in valid("runs").splitlines(True) if not ln.startswith(b"R003")),
         kind=[], order=["--order", "3"], a_min=[])   # 2 runs: 'trend ... +/- nan' reported
def test_stability(runs, kind, order, a_min):
    run_cli("stability", {"runs.csv": runs}, lambda d: [
        "stability", d / "runs.csv", *kind, *order, *a_min])


@given(rates=st.one_of(st.none(), maybe_csv("gate_rates")), delta=opt("--delta"),
       delta_err=opt("--delta-err"), no_paper=st.booleans())
@example(rates=None, delta=[], delta_err=["--delta-err", "1e308"], no_paper=False)  # inf, nan
@example(rates=mutate_csv(base_texts()["gate_rates"], [("cell", 0, 2, "1e-320")]), delta=[],
         delta_err=[], no_paper=False)                 # gate time inf: 'inf +/- nan' reported
@example(rates=mutate_csv(base_texts()["gate_rates"], [("cell", 0, 2, "2.2e-306")]), delta=[],
         delta_err=[], no_paper=False)                 # gate time 4e308 us: 'inf' reported
def test_budget(rates, delta, delta_err, no_paper):
    files = {} if rates is None else {"rates.csv": rates}
    run_cli("budget", files, lambda d: [
        "budget", *delta, *delta_err, *(["--gate-rates", d / "rates.csv"] if files else []),
        *(["--no-paper"] if no_paper else [])])


def usually(good, other):
    """``good`` half of the time (so that the other options' checks are reached too)."""
    return st.one_of(st.just(good), other)


@given(runs=maybe_csv("runs"), A=usually("0.5", number_texts()), stale=opt("--stale-days"),
       draws=usually("50", small_ints(-1, 200)), walkers=usually("16", small_ints(-1, 40)),
       steps=usually("20", small_ints(-1, 30)),
       order=opt("--order", small_ints(-1, 9)), loss=opt("--loss"),
       seed=opt("--seed", small_ints(-2, 5)))
@example(runs=valid("runs"), A="0.5", stale=[], draws="1", walkers="1", steps="1", order=[],
         loss=[], seed=[])                             # 'n_walkers ...': no option named
@example(runs=valid("runs"), A="0.5", stale=[], draws="50", walkers="16", steps="20", order=[],
         loss=["--loss", "1"], seed=[])                # loss never reached: TypeError in report
@example(runs=valid("runs"), A="0.5", stale=[], draws="50", walkers="16", steps="20",
         order=["--order", "1"], loss=[], seed=[])    # K = 1: nothing sampled, 'tau nan' reported
def test_propagate(runs, A, stale, draws, walkers, steps, order, loss, seed):
    run_cli("propagate", {"runs.csv": runs}, lambda d: [
        "propagate", "--calibration-runs", d / "runs.csv", "--A", A, *stale,
        "--draws", draws, "--walkers", walkers, "--steps", steps, *order, *loss, *seed,
        "--force", "--no-progress"])


# ----------------------------------------------------------------------------- the baseline

_VALID_RUNS = [
    ("calibrate", {"amp.csv": "amplitude", "phase.csv": "phase"},
     ["--amplitude", "@amp.csv", "--phase", "@phase.csv", "--order-scan", "none",
      "-o", "@cal.json"], ["cal.json"]),
    ("sweep", {"cal.json": "calibration"},
     ["@cal.json", "--amplitudes", "0.2:1:5", "-o", "@s.csv"], ["s.csv"]),
    ("lut", {"cal.json": "calibration"}, ["@cal.json", "--points", "50", "-o", "@l.csv"],
     ["l.csv", "l.json"]),
    ("estimate", {}, ["--powers-db", "0:-40,1:0,2:0,3:-30"], []),
    ("fidelity", {"pop.csv": "populations", "par.csv": "parity", "rates.csv": "gate_rates"},
     ["--populations", "@pop.csv", "--parity", "@par.csv", "--gate-rates", "@rates.csv",
      "-o", "@g.csv"], ["g.csv"]),
    ("thresholds", {"sweep.csv": "sweep"}, ["@sweep.csv"], []),
    ("align", {"gate.csv": "gate", "sweep.csv": "sweep"},
     ["--gate", "@gate.csv", "--sweep", "@sweep.csv"], []),
    ("stability", {"runs.csv": "runs"}, ["@runs.csv", "--order", "4"], []),
    ("budget", {"rates.csv": "gate_rates"},
     ["--delta", "-0.01", "--delta-err", "0.003", "--gate-rates", "@rates.csv"], []),
    ("propagate", {"runs.csv": "runs"},
     ["--calibration-runs", "@runs.csv", "--A", "0.5", "--draws", "50", "--walkers", "16",
      "--steps", "20", "--force", "--no-progress"], []),
]


@pytest.mark.parametrize("command, files, args, outputs", _VALID_RUNS,
                         ids=[r[0] for r in _VALID_RUNS])
def test_the_unmutated_inputs_give_a_valid_result(command, files, args, outputs):
    """The files every property test mutates are valid: exit 0 with finite outputs."""
    code = run_cli(f"{command} (valid)", {n: valid(k) for n, k in files.items()},
                   lambda d: [command, *[d / a[1:] if a.startswith("@") else a for a in args]],
                   outputs)
    assert code == 0
