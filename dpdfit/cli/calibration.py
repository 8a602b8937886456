"""``dpdfit polyfit``, ``dpdfit calibrate`` and ``dpdfit lut``: fits of the calibration runs.

``polyfit`` is the bare weighted polynomial fit of two CSV columns;
``calibrate`` fits the AOM amplitude (and phase) transfer functions of one run
(or of every run, ``--all-runs``); ``lut`` exports the predistortion table of
a ``calibration.json`` as CSV, ``.npy`` and ``.json`` with its provenance.

The fits are imported by the functions that run the commands, so that registering the
commands' options (``dpdfit --help``) does not load them.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import sys
from pathlib import Path

import numpy as np

from dpdfit.cli.help_texts import SUMMARIES
from dpdfit.cli.options import positive_int, unit_interval
from dpdfit.core.defaults import AMPLITUDE_ORDER, PHASE_MIN_A, PHASE_ORDER
from dpdfit.core.version import __version__
from dpdfit.errors import DpdfitError, FitError, InputError, NotInvertibleError
from dpdfit.recordings.outputs import (atomic_write_json, refuse_overwriting_inputs, sha256_file,
                                       staged_outputs, to_jsonable)

__all__ = ["add_polyfit_command", "add_calibrate_command", "add_lut_command",
           "cmd_polyfit", "cmd_calibrate", "cmd_lut"]


# ----------------------------------------------------------------------------- polyfit


def cmd_polyfit(args) -> int:
    """``dpdfit polyfit``: weighted polynomial fit of two CSV columns (report with the
    covariance, or JSON; ``-o`` also writes the JSON)."""
    # here, not at the top: --help registers the options without loading the fits
    from dpdfit.fits.polyfit import parse_powers, polyfit
    from dpdfit.recordings.tables import read_table
    cols = [args.x, args.y]
    df = read_table(args.file, cols + ([args.sigma] if args.sigma else []),
                    positive=[args.sigma] if args.sigma else [])
    powers = parse_powers(args.powers)
    try:
        res = polyfit(df[args.x].to_numpy(), df[args.y].to_numpy(), powers,
                      sigma=df[args.sigma].to_numpy() if args.sigma else None)
    except FitError as exc:
        raise FitError(f"{args.file}: {exc}") from None
    d = res.to_dict()
    if args.output:
        refuse_overwriting_inputs([args.output], [args.file])
        atomic_write_json(args.output, d)
    if args.json:
        print(json.dumps(to_jsonable(d), indent=2))
    else:
        print(res.report())
        cov = np.asarray(res.covariance)
        names = [f"c{k}" for k in res.powers]
        print("[[Covariance]]")
        print("    " + " ".join(f"{n:>12s}" for n in names))
        for n, row in zip(names, cov):
            print(f"{n:>4s}" + " ".join(f"{v:12.4e}" for v in row))
    return 0


def add_polyfit_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit polyfit`` on an argparse sub-parsers object."""
    q = subparsers.add_parser("polyfit", help=SUMMARIES["polyfit"])
    q.add_argument("file", help="CSV file")
    q.add_argument("--x", required=True, help="column of the abscissa")
    q.add_argument("--y", required=True, help="column of the ordinate")
    q.add_argument("--powers", required=True,
                   help="powers: inclusive range '0:10' or list '1,2,5'")
    q.add_argument("--sigma", help="column of 1-sigma uncertainties of y (absolute)")
    q.add_argument("--json", action="store_true", help="print JSON instead of a report")
    q.add_argument("-o", "--output", help="also write the JSON result to this file")
    q.set_defaults(func=cmd_polyfit)
    return q


# ----------------------------------------------------------------------------- calibrate


def _order_range(spec: str):
    # here, not at the top: --help registers the options without loading the fits
    from dpdfit.fits.polyfit import parse_powers
    if spec.lower() in ("none", "off", ""):
        return None
    try:
        orders = parse_powers(spec)
    except DpdfitError as exc:
        raise InputError(f"--order-scan: {exc}") from None
    if min(orders) < 1:
        raise InputError(f"--order-scan: orders must be >= 1, got {spec}")
    return orders


def _amplitude_runs(args) -> list[dict]:
    """Fit every amplitude run of ``--amplitude``; print one line per run."""
    # here, not at the top: --help registers the options without loading the fits
    from dpdfit.fits.calibration import calibrate_amplitude
    from dpdfit.fits.calibration.shared import run_record
    from dpdfit.recordings.calibration_runs import calibration_runs_data
    from dpdfit.recordings.tables import read_calibration_table
    runs = calibration_runs_data(read_calibration_table(args.amplitude, "amplitude"),
                                 "amplitude")
    out = []
    print(f"{'run':>12s}  {'timestamp':25s}  {'A_corr':>10s}  {'stderr':>9s}  monotone  red.chi2")
    for r, data in runs.items():
        cal = calibrate_amplitude(data, args.order)
        rec = run_record(cal, "amplitude")
        out.append(rec)
        print(f"{str(r):>12s}  {str(rec['timestamp']):25s}  {cal.A_corr:10.6f}  "
              f"{cal.A_corr_stderr:9.6f}  {'yes' if cal.monotone else 'NO':8s}  "
              f"{cal.reduced_chi2:.3f}")
    return out


def _phase_runs(args) -> list[dict]:
    """Fit every phase run of ``--phase``; print one line per run."""
    # here, not at the top: --help registers the options without loading the fits
    from dpdfit.fits.calibration import calibrate_phase
    from dpdfit.fits.calibration.shared import run_record
    from dpdfit.recordings.calibration_runs import calibration_runs_data
    from dpdfit.recordings.tables import read_calibration_table
    runs = calibration_runs_data(read_calibration_table(args.phase, "phase"), "phase")
    out = []
    print(f"{'phase run':>12s}  {'timestamp':25s}  {'phi(1)':>10s}  {'stderr':>9s}")
    for r, data in runs.items():
        ph = calibrate_phase(data, args.phase_order, args.phase_min_A, args.phase_max_A)
        rec = run_record(ph, "phase")
        out.append(rec)
        print(f"{str(r):>12s}  {str(rec['timestamp']):25s}  {ph.phi_at_1:10.6f}  "
              f"{ph.phi_at_1_stderr:9.6f}")
    return out


def _all_runs(args) -> int:
    out = {"dpdfit_version": __version__, "amplitude_runs": _amplitude_runs(args),
           "phase_runs": _phase_runs(args) if args.phase else []}
    if args.output:
        atomic_write_json(args.output, out)
        print(f"wrote {args.output}", file=sys.stderr)
    return 0


def _check_invertible(amp, data) -> None:
    """Refuse (before anything is written) a fit with no inverse on [0, A_corr].

    A curve that rolls off after peaking above ``A_corr`` is invertible and kept
    (``lut`` reports it, ``lut --strict`` refuses it); see the documentation's calibration guide.
    """
    # here, not at the top: --help registers the options without loading the fits
    from dpdfit.models.transfer import TransferFunction
    where = str(data.source) + (f", run {data.run}" if data.run else "")
    try:
        TransferFunction(amp.powers, tuple(amp.coefficients), source=where).invertibility()
    except NotInvertibleError as exc:
        raise NotInvertibleError(f"{exc}; no predistortion table can be built from it, "
                                 "nothing written", exc.amplitude) from None


def cmd_calibrate(args) -> int:
    """``dpdfit calibrate``: fit the AOM amplitude (and phase) transfer functions of
    one run, or of every run with ``--all-runs``; writes ``calibration.json`` and the
    Fig. 1 panels when asked, prints the report (or JSON)."""
    # here, not at the top: --help registers the options without loading the fits
    from dpdfit.fits.calibration import Calibration, calibrate_amplitude, calibrate_phase
    from dpdfit.recordings.tables import read_calibration
    inputs = [args.amplitude] + ([args.phase] if args.phase else [])
    refuse_overwriting_inputs([args.output], inputs)
    if args.phase and not args.phase_min_A < args.phase_max_A:
        raise InputError(f"option --phase-min-A: must be < --phase-max-A "
                         f"({args.phase_max_A:g}), got {args.phase_min_A:g}")
    if args.all_runs:
        return _all_runs(args)
    scan = _order_range(args.order_scan)
    amp_data = read_calibration(args.amplitude, "amplitude", args.run)
    amp = calibrate_amplitude(amp_data, args.order, order_scan=scan)
    _check_invertible(amp, amp_data)
    ph_data = ph = None
    if args.phase:
        ph_data = read_calibration(args.phase, "phase", args.phase_run)
        ph = calibrate_phase(ph_data, args.phase_order, args.phase_min_A, args.phase_max_A)
    cal = Calibration(amplitude=amp, phase=ph)
    figures = {}
    if args.plot:  # drawn before anything is written: a failing figure writes nothing
        from dpdfit.report.calibration_plots import calibration_figures
        from dpdfit.report.figure_io import use_noninteractive_backend
        use_noninteractive_backend()
        figures = calibration_figures(cal, amp_data, ph_data)
    if args.output:
        atomic_write_json(args.output, cal.to_dict())
    if args.json:
        print(json.dumps(to_jsonable(cal.to_dict()), indent=2))
    else:
        print(cal.report())
        if args.output:
            print(f"wrote {args.output}", file=sys.stderr)
    if figures:
        from dpdfit.report.figure_io import save_figures
        for p in save_figures(figures, args.plot):
            print(f"wrote {p}", file=sys.stderr)
    return 0


def add_calibrate_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit calibrate`` on an argparse sub-parsers object."""
    c = subparsers.add_parser("calibrate",
                              help=SUMMARIES["calibrate"])
    c.add_argument("--amplitude", required=True, metavar="AMP.csv",
                   help="columns A, power[, power_err, run, timestamp]")
    c.add_argument("--phase", metavar="PHASE.csv",
                   help="columns A, phase_rad[, phase_err, run, timestamp]")
    c.add_argument("--order", type=positive_int, default=AMPLITUDE_ORDER,
                   help=f"amplitude polynomial order K ({AMPLITUDE_ORDER})")
    c.add_argument("--phase-order", type=positive_int, default=PHASE_ORDER,
                   help=f"phase polynomial order K ({PHASE_ORDER})")
    c.add_argument("--phase-min-A", type=unit_interval, default=PHASE_MIN_A,
                   help=f"lower end of the phase fit window ({PHASE_MIN_A})")
    c.add_argument("--phase-max-A", type=unit_interval, default=1.0,
                   help="upper end of the phase fit window (1.0)")
    c.add_argument("--run", help="amplitude run to fit (label, or 'latest')")
    c.add_argument("--phase-run", help="phase run to fit (label, or 'latest')")
    c.add_argument("--all-runs", action="store_true",
                   help="fit every run of the file(s) and write a per-run table")
    c.add_argument("--order-scan", default="3:12",
                   help="orders for the AIC/BIC table, e.g. '3:12' or 'none' (3:12)")
    c.add_argument("-o", "--output", help="calibration JSON to write")
    c.add_argument("--json", action="store_true", help="print the JSON instead of a report")
    c.add_argument("--plot", metavar="DIR", help="write Fig. 1 panels (PNG) into DIR")
    c.set_defaults(func=cmd_calibrate)
    return c


# ----------------------------------------------------------------------------- lut


def _lut_provenance(args, amp, a_star, rolloff) -> dict:
    """The provenance written into the table's header and ``.json``."""
    return {
        "dpdfit_version": __version__,
        "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "calibration_file": str(args.calibration),
        "calibration_sha256": sha256_file(args.calibration),
        "amplitude_input_file": amp.source.get("file"),
        "amplitude_input_sha256": amp.source.get("sha256"),
        "amplitude_run": amp.source.get("run"),
        "amplitude_timestamp": amp.source.get("timestamp"),
        "order": amp.order,
        "A_corr": amp.A_corr,
        "A_corr_stderr": amp.A_corr_stderr,
        "points": int(args.points),
        "columns": ["target_amplitude", "rf_amplitude", "clamped"],
        "inverse_branch_top": a_star,
        "rolloff_intervals": [list(iv) for iv in rolloff],
        "description": "target normalised optical amplitude -> RF amplitude (f_AM^-1); "
                       "targets >= A_corr are clamped to full drive (1.0)",
    }


def cmd_lut(args) -> int:
    """``dpdfit lut``: write the predistortion table of a ``calibration.json`` as CSV,
    ``.npy`` and ``.json`` (its provenance), all three or none."""
    # here, not at the top: --help registers the options without loading the fits
    from dpdfit.fits.calibration import load_calibration
    from dpdfit.models.transfer import TransferFunction, predistortion_table
    out_csv = Path(args.output)
    if out_csv.suffix.lower() != ".csv":
        raise InputError("output must end in .csv (the .npy and .json are written beside it)",
                         file=str(out_csv))
    out_npy = out_csv.with_suffix(".npy")
    out_json = out_csv.with_suffix(".json")
    refuse_overwriting_inputs([out_csv, out_npy, out_json], [args.calibration])
    if args.points < 2:
        raise InputError(f"--points must be >= 2, got {args.points}")
    cal = load_calibration(args.calibration)
    tf = TransferFunction.from_calibration(cal)
    target, rf, clamped = predistortion_table(tf, args.points, strict=args.strict)
    a_star, rolloff = tf.invertibility()
    amp = cal.amplitude
    prov = _lut_provenance(args, amp, a_star, rolloff)
    header = "".join(f"# {k}: {json.dumps(to_jsonable(v))}\n" for k, v in prov.items())
    body = "target_amplitude,rf_amplitude,clamped\n" + "".join(
        f"{float(t)!r},{float(r)!r},{int(c)}\n" for t, r, c in zip(target, rf, clamped))
    with staged_outputs() as stage:
        stage(out_csv).write_text(header + body)
        with open(stage(out_npy), "wb") as fh:
            np.save(fh, np.column_stack([target, rf]))
        stage(out_json).write_text(json.dumps(to_jsonable(prov), indent=2) + "\n")
    print(f"predistortion table: {args.points} points, A_corr = {amp.A_corr:.6f}"
          + (f"; fitted y(A) rolls off after its peak, inverse reaches A_corr at "
             f"A = {a_star:.6f}" if rolloff else ""))
    print(f"wrote {out_csv}\nwrote {out_npy}\nwrote {out_json}", file=sys.stderr)
    return 0


def add_lut_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit lut`` on an argparse sub-parsers object."""
    t = subparsers.add_parser("lut", help=SUMMARIES["lut"])
    t.add_argument("calibration", help="calibration.json written by 'dpdfit calibrate'")
    t.add_argument("--points", type=int, default=1001, help="number of table points (1001)")
    t.add_argument("-o", "--output", required=True, help="output .csv (writes .npy/.json beside)")
    t.add_argument("--strict", action="store_true",
                   help="refuse a fit that rolls off after its peak (not monotone on [0,1])")
    t.set_defaults(func=cmd_lut)
    return t
