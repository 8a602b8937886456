"""Re-run a fixed set of broken-input cases and classify each outcome.

    python scripts/broken_input_cases.py       # table + counts on stdout

Each case is one command (run in-process through ``dpdfit.cli.main.main``) on
a broken copy of the bundled data, or one Python-API call.  Outcomes:

``clean``  exit 2, exactly one ``dpdfit: error:`` line naming the place (file,
           column/row or option), no traceback, inputs unchanged;
``ok``     exit 0 and the case's own check of the result passes (e.g. a warning
           for phases in degrees, finite numbers);
``vague``  exit 2 with one line that does not name the place;
``wrong``  anything else (traceback, exit 0 with NaN/empty output, a changed input).

Each case belongs to a group (first column): ``calibration`` (a NaN in a calibration
file), ``option`` (an option value out of range or NaN), ``table`` (bad rows in a
sweep or gate table), ``analyze`` (a broken campaign folder), ``diagnose`` (an
impossible count) and ``message`` (a refusal must name its file, column or row).
"""

from __future__ import annotations

import contextlib
import io
import json
import logging
import os
import re
import shutil
import sys
import tempfile
import traceback
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
AMP = ROOT / "datasets" / "synthetic_aom" / "calibration_amplitude.csv"
CAMP = ROOT / "datasets" / "synthetic_campaign"


def run(argv):
    """(exit code, stdout, stderr incl. log lines, traceback or None)."""
    from dpdfit.cli.main import main
    out, err = io.StringIO(), io.StringIO()
    handler = logging.StreamHandler(err)
    logging.getLogger("dpdfit").addHandler(handler)
    tb = None
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main([str(a) for a in argv])
    except BaseException:  # noqa: BLE001 -- a traceback is what we count
        code, tb = None, traceback.format_exc()
    finally:
        logging.getLogger("dpdfit").removeHandler(handler)
    return code, out.getvalue(), err.getvalue(), tb


def classify(argv, place, inputs=(), check=None):
    """The outcome of one CLI case (see the module docstring)."""
    inputs = [Path(p) for p in inputs]
    before = {p: p.read_bytes() for p in inputs}
    code, out, err, tb = run(argv)
    changed = any(p.read_bytes() != b for p, b in before.items())
    lines = [ln for ln in err.strip().splitlines() if ln.startswith("dpdfit: error:")]
    if tb or changed or "Traceback" in err:
        return "wrong", (tb or err).strip().splitlines()[-1] if (tb or err) else "input changed"
    if code == 2 and len(lines) == 1:
        named = all(p in lines[0] for p in ([place] if isinstance(place, str) else place))
        return ("clean" if named and "np.float64" not in lines[0] else "vague"), lines[0]
    if code == 0 and check is not None:
        verdict = check(out, err)
        return ("ok" if verdict is True else "wrong"), (verdict if verdict is not True else "ok")
    return "wrong", f"exit {code}: {(err or out).strip()[-160:]}"


def api_case(call, types=("DpdfitError",)):
    """The outcome of one Python-API case: a typed dpdfit error is ``clean``."""
    try:
        call()
    except Exception as exc:  # noqa: BLE001
        kind = type(exc).__mro__
        if any(k.__name__ in types for k in kind):
            return "clean", f"{type(exc).__name__}: {exc}"
        return "wrong", f"untyped {type(exc).__name__}: {exc}"
    return "wrong", "no error"


def edit_csv(src, dst, fn):
    """Copy a CSV (comment lines kept) with its table changed by ``fn(DataFrame)``."""
    text = Path(src).read_text().splitlines(keepends=True)
    head = [ln for ln in text if ln.startswith("#")]
    df = pd.read_csv(src, comment="#")
    df = fn(df)
    Path(dst).write_text("".join(head) + df.to_csv(index=False))
    return Path(dst)


def made(tmp):
    from dpdfit.cli.main import main
    cal, sweep, gate = tmp / "c.json", tmp / "s.csv", tmp / "g.csv"
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert main(["calibrate", "--amplitude", str(AMP), "-o", str(cal)]) == 0
        assert main(["sweep", str(cal), "-o", str(sweep)]) == 0
        assert main(["fidelity", "--populations", str(CAMP / "populations.csv"), "--parity",
                     str(CAMP / "parity.csv"), "--gate-rates", str(CAMP / "gate_rates.csv"),
                     "-o", str(gate)]) == 0
    return cal, sweep, gate


def cases(tmp):
    """(group, name, outcome, detail) of every case."""
    cal, sweep, gate = made(tmp)
    d = json.loads(cal.read_text())
    d["amplitude"]["coefficients"][3] = float("nan")
    nan_cal = tmp / "nan_cal.json"
    nan_cal.write_text(json.dumps(d))
    o = tmp / "o"
    o.mkdir()
    yield from (("calibration", f"NaN coefficient: {c}", *classify([c, nan_cal, "-o", o / "x.csv"],
                                                                   "nan_cal.json", [nan_cal]))
                          for c in ("lut", "sweep"))
    yield "option", "sweep --nu 1e12", *classify(["sweep", cal, "--nu", "1e12", "-o", o / "s.csv"],
                                                 "--nu")
    runs = CAMP / "calibration_amplitude.csv"
    for argv, opt in ((["sweep", cal, "--nbar", "nan", "-o", o / "s.csv"], "--nbar"),
                      (["estimate", "--powers-db", "0:-40,1:0,2:0,3:-30", "--nbar", "nan"],
                       "--nbar"),
                      (["propagate", "--calibration-runs", runs, "--A", "0.5",
                        "--stale-days", "nan"], "--stale-days"),
                      (["im-table", "--nbar", "nan"], "--nbar"),
                      (["align", "--gate", gate, "--sweep", sweep, "--sigma-db", "nan"],
                       "--sigma-db"),
                      (["thresholds", sweep, "--A-corr", "2"], "--A-corr"),
                      (["thresholds", sweep, "--A-corr", "nan"], "--A-corr")):
        yield "option", " ".join(map(str, argv[:1] + argv[-2:])), *classify(argv, opt)
    yield from _table_cases(tmp, cal, sweep, gate, o)
    yield from _analyze_cases(tmp, o)
    yield from _message_cases(tmp, cal, sweep, gate, o)


def _table_cases(tmp, cal, sweep, gate, o):
    def dup_mean(df):
        row = df[df["sideband"] == "mean"].iloc[[0]] if "sideband" in df else df.iloc[[0]]
        return pd.concat([df, row])
    dsw = edit_csv(sweep, tmp / "dup_sweep.csv", dup_mean)
    yield "table", "sweep.csv duplicated mean row: thresholds", *classify(["thresholds", dsw],
                                                                          "dup_sweep.csv", [dsw])
    yield "table", "sweep.csv duplicated mean row: align", *classify(
        ["align", "--gate", gate, "--sweep", dsw], "dup_sweep.csv", [dsw])

    def a15(df):
        df = df.copy()
        df.loc[df.index[df["sideband"] == "mean"][0], "A"] = 1.5
        return df
    asw = edit_csv(sweep, tmp / "a15_sweep.csv", a15)
    yield "table", "sweep.csv A=1.5 on a mean row", *classify(["thresholds", asw], "a15_sweep.csv",
                                                              [asw])
    gr = CAMP / "gate_rates.csv"
    dgr = edit_csv(gr, tmp / "dup_rates.csv", lambda df: pd.concat([df, df.iloc[[0]]]))
    args = ["fidelity", "--populations", CAMP / "populations.csv", "--parity", CAMP / "parity.csv"]
    yield "table", "gate_rates.csv duplicated row", *classify(
        args + ["--gate-rates", dgr, "-o", o / "g.csv"], "dup_rates.csv", [dgr])

    def a15r(df):
        df = df.copy()
        df.loc[df.index[0], "A"] = 1.5
        return df
    agr = edit_csv(gr, tmp / "a15_rates.csv", a15r)
    yield "table", "gate_rates.csv A=1.5", *classify(
        args + ["--gate-rates", agr, "-o", o / "g.csv"],
        "a15_rates.csv", [agr])

    def f17(df):
        df = df.copy()
        df.loc[df.index[0], "F"] = 1.7
        return df
    fg = edit_csv(gate, tmp / "f17_gate.csv", f17)
    yield "table", "align F=1.7", *classify(
        ["align", "--gate", fg, "--sweep", sweep], "f17_gate.csv",
        [fg])


def _camp_copy(tmp, name, edit=None):
    dst = tmp / name
    shutil.copytree(CAMP, dst, ignore=shutil.ignore_patterns("traces"))
    if edit:
        edit(dst)
    return dst


def _analyze(folder, o, *extra):
    return ["analyze", folder, "-o", o, "--no-plots", "--no-diagnosis", *extra]


def _analyze_cases(tmp, o):
    def text_in(col):
        def edit(dst):
            edit_csv(dst / "spectra.csv", dst / "spectra.csv",
                     lambda df: df.astype({col: object}).assign(**{col: ["x"] + list(df[col][1:])}))
        return edit
    for col in ("A", "P_dB"):
        c = _camp_copy(tmp, f"text_{col}", text_in(col))
        yield "analyze", f"analyze: text in spectra.csv {col}", *_analyze_failed(
            _analyze(c, o / f"r_{col}"), ["spectra.csv", f"'{col}'"])
    for name, meta in (("list", [1, 2]), ("order", "eight")):
        def edit(dst, meta=meta):
            m = json.loads((dst / "campaign.json").read_text())
            (dst / "campaign.json").write_text(json.dumps(meta if name == "list" else
                                                          {**m, "order": meta}))
        c = _camp_copy(tmp, f"cj_{name}", edit)
        yield "analyze", f"analyze: campaign.json {name}", *classify(_analyze(c, o / f"r_{name}"),
                                                                     "campaign.json")
    empty = tmp / "empty"
    empty.mkdir()
    yield "analyze", "analyze: empty folder", *classify(_analyze(empty, o / "r_empty"), "empty")


def _analyze_failed(argv, places):
    """analyze with one failed analysis: exit 2, its one error line names the place."""
    code, out, err, tb = run(argv)
    lines = [ln for ln in err.splitlines() if "error" in ln.lower()]
    if tb or "Traceback" in err:
        return "wrong", (tb or err).strip().splitlines()[-1]
    ok = code == 2 and any(all(p in ln for p in places) for ln in lines)
    return ("clean" if ok else "vague"), (lines[0] if lines else f"exit {code}")


def _message_cases(tmp, cal, sweep, gate, o):
    from dpdfit.fits.calibration import load_calibration
    from dpdfit.recordings.tables import read_calibration
    yield "message", "analyze -o <input file>", *classify(
        _analyze(CAMP, CAMP / "spectra.csv"), "spectra.csv", [CAMP / "spectra.csv"])
    f = tmp / "afile"
    f.write_text("x")
    yield "message", "--plot pointing at a file", *classify(
        ["sweep", cal, "-o", o / "s2.csv", "--plot", f], ["--plot", "afile"])
    dup = edit_csv(AMP, tmp / "dup_amp.csv", lambda df: pd.concat([df, df.iloc[[3]]]))
    yield "message", "calibrate: exact duplicate line", *classify(
        ["calibrate", "--amplitude", dup, "-o", o / "c2.json"], "dup_amp.csv", [dup])
    dup_runs = edit_csv(CAMP / "calibration_amplitude.csv", tmp / "dup_runs.csv",
                        lambda df: pd.concat([df, df.iloc[[3]]]))
    yield "message", "stability: exact duplicate line", *classify(["stability", dup_runs],
                                                                 "dup_runs.csv", [dup_runs])
    dg = edit_csv(gate, tmp / "dup_gate.csv", lambda df: pd.concat([df, df.iloc[[0]]]))
    yield "message", "align: exact duplicate line", *classify(
        ["align", "--gate", dg, "--sweep", sweep],
        "dup_gate.csv", [dg])
    dgr = edit_csv(CAMP / "gate_rates.csv", tmp / "dup_rates_b.csv",
                   lambda df: pd.concat([df, df.iloc[[0]]]))
    yield "message", "budget: exact duplicate line", *classify(["budget", "--gate-rates", dgr],
                                                              "dup_rates_b.csv", [dgr])

    def degrees(df):
        df = df.copy()
        df["phase_rad"] = np.degrees(df["phase_rad"])
        return df
    par = edit_csv(CAMP / "parity.csv", tmp / "deg_parity.csv", degrees)
    yield "message", "parity phases in degrees", *classify(
        ["fidelity", "--populations", CAMP / "populations.csv", "--parity", par],
        "deg_parity.csv", [par], check=lambda out, err: True if "degree" in err else
        "no warning about degrees")
    nocj = _camp_copy(tmp, "no_cj", lambda d: (d / "campaign.json").unlink())
    yield "message", "analyze: missing campaign.json", *classify(_analyze(nocj, o / "r_nocj"),
                                                                 "campaign.json")
    old = os.umask(0o022)
    try:
        run(["lut", cal, "-o", o / "mode.csv"])
    finally:
        os.umask(old)
    mode = (o / "mode.csv").stat().st_mode & 0o777
    yield "message", "output mode under umask 022", ("ok" if mode == 0o644 else "wrong"), oct(mode)
    yield "message", "API: calibration CSV is a folder", *api_case(
        lambda: read_calibration(tmp, "amplitude"))
    yield from _location_cases(tmp, cal, sweep, gate, o)
    yield "message", "API: calibration JSON missing key", *api_case(
        lambda: load_calibration(_json(tmp / "k.json", {"phase": None})))


def _location_cases(tmp, cal, sweep, gate, o):
    """Messages that must name their file/column/row, and the n00 > shots time scan."""
    def bend(df):  # the response falls above A = 0.8: no monotone inverse
        df = df.copy()
        hi = df["A"] > 0.8
        df.loc[hi, "power"] = df.loc[hi, "power"].max() * (1.8 - df.loc[hi, "A"])
        return df
    bent = edit_csv(AMP, tmp / "bent_amp.csv", bend)

    def used_range_invertible(out, err):
        """Accepted (README): the fit falls only above A_corr, where no table is built."""
        a_corr = json.loads((o / "bent.json").read_text())["A_corr"]
        m = re.search(r"dy/dA < 0 on \[([0-9.]+), ([0-9.]+)\]", out)
        if m is None:
            return "no monotonicity report"
        return True if float(m.group(1)) > a_corr else f"falls at {m.group(1)} < A_corr {a_corr}"
    yield "message", "calibrate: fit falling above A_corr", *classify(
        ["calibrate", "--amplitude", bent, "-o", o / "bent.json"], "bent_amp.csv", [bent],
        check=used_range_invertible)

    def dip(df):  # the response falls inside [0, A_corr]: refused, nothing written
        df = df.copy()
        m = (df["A"] > 0.3) & (df["A"] < 0.5)
        df.loc[m, "power"] = df.loc[df["A"] <= 0.3, "power"].iloc[-1] - (df.loc[m, "A"] - 0.3) / 2
        return df
    dipped = edit_csv(AMP, tmp / "dip_amp.csv", dip)
    yield "message", "calibrate: fit falling below A_corr", *classify(
        ["calibrate", "--amplitude", dipped, "-o", o / "dip.json"], "dip_amp.csv", [dipped])
    neg = edit_csv(gate, tmp / "negerr_gate.csv",
                   lambda df: df.assign(xi0_err_khz=[-1.0] + list(df["xi0_err_khz"][1:])))
    yield "message", "align: xi0_err_khz < 0", *classify(
        ["align", "--gate", neg, "--sweep", sweep],
        ["negerr_gate.csv", "xi0_err_khz"], [neg])

    def n00(dst):
        edit_csv(dst / "time_scans.csv", dst / "time_scans.csv",
                 lambda df: df.assign(n00=[900] + list(df["n00"][1:])))
    c = _camp_copy(tmp, "n00", n00)
    yield "diagnose", "diagnose: n00 > shots", *classify(
        ["diagnose", c], ["time_scans.csv", "n00"])


def _json(path, obj):
    path.write_text(json.dumps(obj))
    return path


def main():
    logging.getLogger("dpdfit").setLevel(logging.INFO)
    with tempfile.TemporaryDirectory() as t:
        rows = list(cases(Path(t)))
    width = max(len(r[1]) for r in rows)
    for group, name, outcome, detail in rows:
        print(f"{group:<11}  {name:<{width}}  {outcome:<6} {detail[:150]}")
    counts = pd.Series([r[2] for r in rows]).value_counts()
    print("\n" + "  ".join(f"{k}: {v}" for k, v in counts.items()), f"(of {len(rows)})")
    return 0 if "wrong" not in counts else 1


if __name__ == "__main__":
    sys.exit(main())
