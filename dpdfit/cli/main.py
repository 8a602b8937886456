"""The ``dpdfit`` command line: a thin layer over the Python API.

Every sub-command validates its inputs through :mod:`dpdfit.recordings.tables`, calls the
API, and writes its outputs atomically.  Any :class:`~dpdfit.errors.DpdfitError`
is printed as one line ``dpdfit: error: ...`` on stderr with exit status 2.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import sys
from pathlib import Path

import numpy as np

from dpdfit.core.version import __version__
from dpdfit.recordings.outputs import (atomic_write_json, read_csv_header, refuse_overwriting_inputs, sha256_file,
                  staged_outputs, to_jsonable, write_csv_with_header)
from dpdfit.fits.calibration import Calibration, calibrate_amplitude, calibrate_phase, load_calibration
from dpdfit.errors import DpdfitError, InputError
from dpdfit.fits.polyfit import parse_powers, polyfit
from dpdfit.recordings.tables import read_calibration, read_table, list_runs
from dpdfit.models.transfer import TransferFunction, predistortion_table

__all__ = ["main", "build_parser"]


def _order_range(spec: str):
    if spec.lower() in ("none", "off", ""):
        return None
    try:
        return parse_powers(spec)
    except DpdfitError as exc:
        raise InputError(f"--order-scan: {exc}") from None


# ----------------------------------------------------------------------------- polyfit


def cmd_polyfit(args) -> int:
    cols = [args.x, args.y]
    df = read_table(args.file, cols + ([args.sigma] if args.sigma else []),
                    positive=[args.sigma] if args.sigma else [])
    powers = parse_powers(args.powers)
    res = polyfit(df[args.x].to_numpy(), df[args.y].to_numpy(), powers,
                  sigma=df[args.sigma].to_numpy() if args.sigma else None)
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


# ----------------------------------------------------------------------------- calibrate


def _all_runs(args) -> int:
    amp_df = read_table(args.amplitude, ["A", "power"], ["power_err", "run", "timestamp"],
                        ranges={"A": (0, 1)}, positive=["power_err"])
    out = {"dpdfit_version": __version__, "amplitude_runs": [], "phase_runs": []}
    runs = list_runs(amp_df) or [None]
    print(f"{'run':>12s}  {'timestamp':25s}  {'A_corr':>10s}  {'stderr':>9s}  monotone  red.chi2")
    for r in runs:
        cal = calibrate_amplitude(read_calibration(args.amplitude, "amplitude", r), args.order)
        rec = {"run": r, "timestamp": cal.source.get("timestamp"), "A_corr": cal.A_corr,
               "A_corr_stderr": cal.A_corr_stderr, "monotone": cal.monotone,
               "reduced_chi2": cal.reduced_chi2, "coefficients": cal.coefficients.tolist(),
               "stderr": cal.stderr.tolist(), "raw_coefficients": cal.raw_coefficients.tolist(),
               "raw_covariance": cal.raw_covariance.tolist(), "n_points": cal.n_points}
        out["amplitude_runs"].append(rec)
        print(f"{str(r):>12s}  {str(rec['timestamp']):25s}  {cal.A_corr:10.6f}  "
              f"{cal.A_corr_stderr:9.6f}  {'yes' if cal.monotone else 'NO':8s}  "
              f"{cal.reduced_chi2:.3f}")
    if args.phase:
        ph_df = read_table(args.phase, ["A", "phase_rad"], ["phase_err", "run", "timestamp"],
                           ranges={"A": (0, 1)}, positive=["phase_err"])
        print(f"{'phase run':>12s}  {'timestamp':25s}  {'phi(1)':>10s}  {'stderr':>9s}")
        for r in list_runs(ph_df) or [None]:
            ph = calibrate_phase(read_calibration(args.phase, "phase", r), args.phase_order,
                                 args.phase_min_A, args.phase_max_A)
            rec = {"run": r, "timestamp": ph.source.get("timestamp"), "phi_at_1": ph.phi_at_1,
                   "phi_at_1_stderr": ph.phi_at_1_stderr, "coefficients": ph.coefficients.tolist(),
                   "stderr": ph.stderr.tolist(), "covariance": ph.covariance.tolist(),
                   "reduced_chi2": ph.reduced_chi2, "n_points": ph.n_points}
            out["phase_runs"].append(rec)
            print(f"{str(r):>12s}  {str(rec['timestamp']):25s}  {ph.phi_at_1:10.6f}  "
                  f"{ph.phi_at_1_stderr:9.6f}")
    if args.output:
        atomic_write_json(args.output, out)
        print(f"wrote {args.output}", file=sys.stderr)
    return 0


def cmd_calibrate(args) -> int:
    inputs = [args.amplitude] + ([args.phase] if args.phase else [])
    refuse_overwriting_inputs([args.output], inputs)
    if args.all_runs:
        return _all_runs(args)
    scan = _order_range(args.order_scan)
    amp_data = read_calibration(args.amplitude, "amplitude", args.run)
    amp = calibrate_amplitude(amp_data, args.order, order_scan=scan)
    ph_data = ph = None
    if args.phase:
        ph_data = read_calibration(args.phase, "phase", args.phase_run)
        ph = calibrate_phase(ph_data, args.phase_order, args.phase_min_A, args.phase_max_A)
    cal = Calibration(amplitude=amp, phase=ph)
    if args.output:
        atomic_write_json(args.output, cal.to_dict())
    if args.json:
        print(json.dumps(to_jsonable(cal.to_dict()), indent=2))
    else:
        print(cal.report())
        if args.output:
            print(f"wrote {args.output}", file=sys.stderr)
    if args.plot:
        from dpdfit.report.plots import plot_calibration
        for p in plot_calibration(cal, args.plot, amp_data, ph_data):
            print(f"wrote {p}", file=sys.stderr)
    return 0


# ----------------------------------------------------------------------------- lut


def cmd_lut(args) -> int:
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
    prov = {
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


# ----------------------------------------------------------------------------- spectra


def _float_arg(name, value, positive=True):
    if value is None or not np.isfinite(value) or (positive and value <= 0):
        raise InputError(f"{name} must be a positive number, got {value}")
    return float(value)


def cmd_sweep(args) -> int:
    from dpdfit.analyses.sweep import SweepConfig, parse_amplitudes, run_sweep, thresholds
    out = Path(args.output)
    refuse_overwriting_inputs([out], [args.calibration])
    cal = load_calibration(args.calibration)
    tf = TransferFunction.from_calibration(cal)
    kw = {}
    if args.amplitudes:
        kw["amplitudes"] = parse_amplitudes(args.amplitudes)
    cfg = SweepConfig(nu=_float_arg("--nu", args.nu), xi0=_float_arg("--xi0", args.xi0),
                      nbar=args.nbar, am_only=args.am_only, formula=args.formula,
                      eta_ref=args.eta_ref, anchor=(args.anchor_A, args.anchor_dpd), **kw)
    df = run_sweep(tf, cfg)
    th = thresholds(df)
    meta = {"dpdfit_version": __version__,
            "calibration_file": str(args.calibration),
            "calibration_sha256": sha256_file(args.calibration),
            **{k: v for k, v in df.attrs.items()}}
    write_csv_with_header(out, df, meta)
    print(f"sweep: {len(cfg.amplitudes)} amplitudes x 2 DPD flags x 3 rows "
          f"({'AM only' if cfg.am_only else 'AM+PM'}, formula {cfg.formula}, nbar {cfg.nbar:g})")
    print(f"A_corr = {tf.A_corr:.6f}; eta_bar_corr: DPD {th['eta_corr']['dpd']}, "
          f"no DPD {th['eta_corr']['no_dpd']}")
    for key in ("no_dpd", "dpd"):
        print(f"eta_th ({key}): " + ", ".join(
            f"{lev}: {'-' if v is None else f'{v:.4f}'}" for lev, v in th["eta_th"][key].items()))
    print(f"wrote {out}", file=sys.stderr)
    if args.plot:
        from dpdfit.report.plots import plot_sweep
        for p in plot_sweep(df, args.plot):
            print(f"wrote {p}", file=sys.stderr)
    return 0


def _parse_powers_db(spec: str) -> tuple[tuple, np.ndarray]:
    items = [s for s in str(spec).split(",") if s.strip()]
    harm, vals = [], []
    for item in items:
        n, sep, v = item.partition(":")
        try:
            if not sep:
                raise ValueError
            harm.append(int(n))
            vals.append(float(v))
        except ValueError:
            raise InputError(f"--powers-db: '{item.strip()}' is not 'n:dB' (expected e.g. "
                             "\"0:-40,1:0,2:0,3:-30\")") from None
    if len(set(harm)) != len(harm):
        raise InputError(f"--powers-db: harmonic given twice in '{spec}'")
    if not np.all(np.isfinite(vals)):
        raise InputError(f"--powers-db: powers must be finite dB values, got '{spec}'")
    for n in (1, 2):
        if n not in harm:
            raise InputError(f"--powers-db: gate tone n={n} is missing in '{spec}'")
    return tuple(harm), np.array(vals)


def cmd_estimate(args) -> int:
    from dpdfit.models.fidelity import estimate
    harm, P = _parse_powers_db(args.powers_db)
    est = estimate(P, harm, nbar=args.nbar, formula=args.formula)
    d = est.to_dict()
    if args.json:
        print(json.dumps(to_jsonable(d), indent=2))
    else:
        print(f"F_est   = {d['F_est']:.9f}   eps_est = {d['eps_est']:.3e}   "
              f"(formula {args.formula}, nbar {args.nbar:g})")
        print(f"F(T_g)  = {d['F']:+.6e}   G(T_g) = {d['G']:+.6e}   Phi(T_g) = {d['Phi']:.9f} rad")
    return 0


def cmd_im_table(args) -> int:
    from dpdfit.models.fidelity import im_requirements
    tab = im_requirements(nbar=args.nbar, formula=args.formula, as_printed=args.as_printed)
    if args.json:
        print(json.dumps(to_jsonable(tab), indent=2))
    else:
        what = ("as printed in Table S2 (assumptions: see README)" if args.as_printed
                else f"formula {args.formula}, nbar {args.nbar:g}")
        print(f"required P_gate/P_IM (dB), {what}")
        print("  infidelity      n=0       n=3")
        for lev in tab["0"]:
            v0, v3 = tab["0"][lev], tab["3"][lev]
            print(f"  {lev:>10s}  {v0:8.2f}  {v3:8.2f}")
    return 0


def cmd_thresholds(args) -> int:
    from dpdfit.analyses.sweep import COLUMNS, thresholds
    df = read_table(args.sweep, COLUMNS, numeric=[c for c in COLUMNS if c != "sideband"])
    bad = ~df["sideband"].isin(["red", "blue", "mean"])
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        raise InputError(f"sideband must be red, blue or mean, got '{df['sideband'].iloc[i]}'",
                         file=str(args.sweep), column="sideband", row=i + 1)
    df["dpd"] = df["dpd"].astype(int)
    meta = read_csv_header(args.sweep)
    A_corr = args.A_corr if args.A_corr is not None else meta.get("A_corr")
    if A_corr is None:
        raise InputError("no A_corr in the sweep file's header; give --A-corr", file=str(args.sweep))
    df.attrs["A_corr"] = float(A_corr)
    res = thresholds(df)
    if args.json:
        print(json.dumps(to_jsonable(res), indent=2))
    else:
        print(f"eta_bar_corr: DPD {res['eta_corr']['dpd']}, no DPD {res['eta_corr']['no_dpd']}")
        for key in ("no_dpd", "dpd"):
            print(f"eta_th ({key}): " + ", ".join(
                f"{lev}: {'-' if v is None else f'{v:.4f}'}" for lev, v in res["eta_th"][key].items()))
    return 0


# ----------------------------------------------------------------------------- counts


GATE_KEYS = ["A", "dpd", "F_pop", "F_pop_err", "F_par", "F_par_err", "F", "F_err", "contrast",
             "phi0", "n_scans", "shots", "interval_method"]


def _gate_table(pop_path, par_path, interval, rates_path=None):
    from dpdfit.fits.counts import gate_fidelities, read_parity, read_populations
    pop = read_populations(pop_path)
    par = read_parity(par_path)
    tab = gate_fidelities(pop, par, interval=interval)
    if rates_path:
        rates = read_table(rates_path, ["A", "dpd", "xi0_khz", "xi0_err_khz"],
                           ranges={"dpd": (0, 1)})
        rates["dpd"] = rates["dpd"].astype(int)
        tab = tab.merge(rates[["A", "dpd", "xi0_khz", "xi0_err_khz"]], on=["A", "dpd"],
                        how="left")
    return tab


def cmd_fidelity(args) -> int:
    outs = [args.output] if args.output else []
    refuse_overwriting_inputs(outs, [args.populations, args.parity, args.gate_rates])
    tab = _gate_table(args.populations, args.parity, args.interval, args.gate_rates)
    records = tab.to_dict(orient="records")
    if args.output:
        from dpdfit.recordings.outputs import atomic_write_text
        atomic_write_text(args.output, tab.to_csv(index=False, float_format="%.10g"))
    if args.json:
        print(json.dumps(to_jsonable(records), indent=2))
    else:
        print(f"{'A':>6s} {'dpd':>3s} {'F_pop':>9s} {'+/-':>7s} {'F_par':>9s} {'+/-':>7s} "
              f"{'F':>9s} {'+/-':>7s} {'scans':>5s} {'shots':>6s}")
        for r in records:
            print(f"{r['A']:6.3f} {int(r['dpd']):3d} {r['F_pop']:9.5f} {r['F_pop_err']:7.5f} "
                  f"{r['F_par']:9.5f} {r['F_par_err']:7.5f} {r['F']:9.5f} {r['F_err']:7.5f} "
                  f"{int(r['n_scans']):5d} {int(r['shots']):6d}")
    if args.plot:
        from dpdfit.fits.counts import merge_parity, read_parity
        from dpdfit.report.plots import plot_parity_only
        par = merge_parity(read_parity(args.parity))
        for p in plot_parity_only(tab, par, args.plot):
            print(f"wrote {p}", file=sys.stderr)
    if args.output:
        print(f"wrote {args.output}", file=sys.stderr)
    return 0


def cmd_align(args) -> int:
    from dpdfit.fits.alignment import align
    gate = read_table(args.gate, ["A", "dpd", "xi0_khz", "xi0_err_khz", "F", "F_err"],
                      numeric=["A", "dpd", "xi0_khz", "xi0_err_khz", "F", "F_err"],
                      ranges={"dpd": (0, 1)})
    from dpdfit.analyses.sweep import COLUMNS
    sweep = read_table(args.sweep, COLUMNS, numeric=[c for c in COLUMNS if c != "sideband"])
    sweep["dpd"] = sweep["dpd"].astype(int)
    meta = read_csv_header(args.sweep)
    sweep.attrs["A_corr"] = meta.get("A_corr")
    fit = align(gate, sweep, args.sigma_db)
    if args.json:
        print(json.dumps(to_jsonable(fit.to_dict()), indent=2))
    else:
        print(fit.report())
    if args.plot:
        from dpdfit.report.plots import plot_gate_figures
        g = gate.copy()
        for p in plot_gate_figures(g, sweep, fit, args.plot):
            print(f"wrote {p}", file=sys.stderr)
    return 0


# ----------------------------------------------------------------------------- campaign


def cmd_simulate_campaign(args) -> int:
    from dpdfit.simulation.campaign import parse_effects, simulate_campaign
    effects = parse_effects(args.effects)
    simulate_campaign(args.outdir, seed=args.seed, effects=effects)
    print(f"wrote campaign {args.outdir} (seed {args.seed}"
          + (f", effects {args.effects}" if effects else "") + ")")
    return 0


def cmd_analyze(args) -> int:
    from dpdfit.pipeline.analyze import analyze
    out = Path(args.output)
    folder = Path(args.folder)
    if folder.resolve() == out.resolve():
        raise InputError("results folder must differ from the campaign folder", file=str(out))
    summary = analyze(folder, out, formula=args.formula, plots=not args.no_plots,
                      diagnosis=not args.no_diagnosis)
    for name, st in summary["analyses"].items():
        print(f"{name:12s} {st['status']:8s} {st['detail']}")
    print(f"results in {out}/ (summary.md, summary.json)")
    return 2 if summary["failures"] else 0


# ----------------------------------------------------------------------------- parser


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="dpdfit", description=__doc__.splitlines()[0])
    p.add_argument("--version", action="version", version=f"dpdfit {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    q = sub.add_parser("polyfit", help="weighted polynomial least squares on a CSV file")
    q.add_argument("file", help="CSV file")
    q.add_argument("--x", required=True, help="column of the abscissa")
    q.add_argument("--y", required=True, help="column of the ordinate")
    q.add_argument("--powers", required=True,
                   help="powers: inclusive range '0:10' or list '1,2,5'")
    q.add_argument("--sigma", help="column of 1-sigma uncertainties of y (absolute)")
    q.add_argument("--json", action="store_true", help="print JSON instead of a report")
    q.add_argument("-o", "--output", help="also write the JSON result to this file")
    q.set_defaults(func=cmd_polyfit)

    c = sub.add_parser("calibrate", help="fit the AOM amplitude (and phase) transfer functions")
    c.add_argument("--amplitude", required=True, metavar="AMP.csv",
                   help="columns A, power[, power_err, run, timestamp]")
    c.add_argument("--phase", metavar="PHASE.csv",
                   help="columns A, phase_rad[, phase_err, run, timestamp]")
    c.add_argument("--order", type=int, default=8, help="amplitude polynomial order K (8)")
    c.add_argument("--phase-order", type=int, default=5, help="phase polynomial order K (5)")
    c.add_argument("--phase-min-A", type=float, default=0.1,
                   help="lower end of the phase fit window (0.1)")
    c.add_argument("--phase-max-A", type=float, default=1.0,
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

    t = sub.add_parser("lut", help="export the predistortion table (CSV + .npy + .json)")
    t.add_argument("calibration", help="calibration.json written by 'dpdfit calibrate'")
    t.add_argument("--points", type=int, default=1001, help="number of table points (1001)")
    t.add_argument("-o", "--output", required=True, help="output .csv (writes .npy/.json beside)")
    t.add_argument("--strict", action="store_true",
                   help="refuse a fit that rolls off after its peak (not monotone on [0,1])")
    t.set_defaults(func=cmd_lut)

    w = sub.add_parser("sweep", help="amplitude sweep: spectra, F_est, eta_bar, r_rel (S6)")
    w.add_argument("calibration", help="calibration.json")
    w.add_argument("--amplitudes", metavar="START:STOP:N",
                   help="inclusive amplitude grid (default 0.05:1:100)")
    w.add_argument("--nbar", type=float, default=0.1, help="thermal phonon number (0.1)")
    w.add_argument("--am-only", action="store_true", help="forward model without AM-to-PM")
    w.add_argument("--xi0", type=float, default=20e3, help="gate detuning, Hz (20e3)")
    w.add_argument("--nu", type=float, default=1.84e6, help="sideband detuning, Hz (1.84e6)")
    w.add_argument("--formula", choices=["exact", "paper"], default="exact",
                   help="Bell-fidelity expression (default exact; see README)")
    w.add_argument("--eta-ref", type=float, default=0.80, help="peak diffraction efficiency (0.80)")
    w.add_argument("--anchor-A", type=float, default=0.4, help="r_rel anchor amplitude (0.4)")
    w.add_argument("--anchor-dpd", type=int, choices=[0, 1], default=0,
                   help="r_rel anchor DPD flag (0)")
    w.add_argument("-o", "--output", required=True, help="sweep table (CSV)")
    w.add_argument("--plot", metavar="DIR", help="write Figs. 2, 5, S4, S6 (PNG) into DIR")
    w.set_defaults(func=cmd_sweep)

    e = sub.add_parser("estimate", help="fidelity estimate from tone powers of one sideband (S5)")
    e.add_argument("--powers-db", required=True, metavar="n:dB,...",
                   help='tone powers, e.g. "0:-40,1:0,2:0,3:-30"')
    e.add_argument("--nbar", type=float, default=0.1, help="thermal phonon number (0.1)")
    e.add_argument("--formula", choices=["exact", "paper"], default="exact")
    e.add_argument("--json", action="store_true")
    e.set_defaults(func=cmd_estimate)

    m = sub.add_parser("im-table", help="required gate-to-IM power ratios (Table S2)")
    m.add_argument("--nbar", type=float, default=0.1, help="thermal phonon number (0.1)")
    m.add_argument("--formula", choices=["exact", "paper"], default="exact")
    m.add_argument("--as-printed", action="store_true",
                   help="use the assumptions that reproduce the printed Table S2")
    m.add_argument("--json", action="store_true")
    m.set_defaults(func=cmd_im_table)

    h = sub.add_parser("thresholds", help="eta_bar_corr and threshold efficiencies of a sweep")
    h.add_argument("sweep", help="sweep.csv written by 'dpdfit sweep'")
    h.add_argument("--A-corr", type=float, dest="A_corr",
                   help="A_corr if the sweep file's header lacks it")
    h.add_argument("--json", action="store_true")
    h.set_defaults(func=cmd_thresholds)

    from dpdfit.fits.heterodyne import add_spectrum_command
    from dpdfit.analyses.stability import add_stability_command
    from dpdfit.analyses.budget import add_budget_command
    from dpdfit.fits.posterior import add_propagate_command
    add_spectrum_command(sub)
    add_stability_command(sub)
    add_propagate_command(sub)
    add_budget_command(sub)
    from dpdfit.analyses.diagnosis.diagnose import add_diagnose_command
    from dpdfit.simulation.harness import add_harness_command
    add_diagnose_command(sub)
    add_harness_command(sub)

    f = sub.add_parser("fidelity", help="Bell fidelities from raw population and parity counts (S7)")
    f.add_argument("--populations", required=True, metavar="POP.csv",
                   help="A, dpd, scan, n_even, shots (or n00, n01_10, n11, shots)")
    f.add_argument("--parity", required=True, metavar="PARITY.csv",
                   help="A, dpd, scan, phase_rad, n_even, shots")
    f.add_argument("--interval", choices=["wilson", "clopper-pearson"], default="wilson",
                   help="population interval near 1 (wilson)")
    f.add_argument("--gate-rates", metavar="RATES.csv", help="A, dpd, xi0_khz, xi0_err_khz: joined into -o")
    f.add_argument("-o", "--output", metavar="GATE.csv", help="write the table as CSV")
    f.add_argument("--json", action="store_true", help="print a JSON list (one record per A, dpd)")
    f.add_argument("--plot", metavar="DIR", help="write the parity-fringe figure (Fig. S8)")
    f.set_defaults(func=cmd_fidelity)

    al = sub.add_parser("align", help="fit alpha (kHz) and delta aligning photodiode curves to gate data")
    al.add_argument("--gate", required=True, help="A, dpd, xi0_khz, xi0_err_khz, F, F_err")
    al.add_argument("--sweep", required=True, help="sweep.csv from 'dpdfit sweep'")
    al.add_argument("--sigma-db", type=float, default=0.2, help="laser-power fluctuation, dB (0.2)")
    al.add_argument("--json", action="store_true")
    al.add_argument("--plot", metavar="DIR", help="write Figs. 3 and 4 (PNG)")
    al.set_defaults(func=cmd_align)

    c = sub.add_parser("simulate-campaign",
                       help="simulate a complete synthetic measurement campaign")
    c.add_argument("outdir", help="new folder to write the campaign into")
    c.add_argument("--seed", type=int, default=20260329, help="random seed (20260329)")
    c.add_argument("--effects", metavar="NAME=STRENGTH,...",
                   help="effects to conceal (see dpdfit.simulation.campaign.EFFECTS)")
    c.set_defaults(func=cmd_simulate_campaign)

    a = sub.add_parser("analyze", help="run every analysis on a campaign folder (main job)")
    a.add_argument("folder", help="campaign folder (campaign.json, calibration_*.csv, ...)")
    a.add_argument("-o", "--output", required=True, help="results folder")
    a.add_argument("--formula", choices=["exact", "paper"], default="exact",
                   help="Bell-fidelity expression for F_est (exact)")
    a.add_argument("--no-plots", action="store_true", help="skip the figures")
    a.add_argument("--no-diagnosis", action="store_true",
                   help="skip the discrepancy diagnosis (the slowest step, ~1 min)")
    a.set_defaults(func=cmd_analyze)
    return p


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except DpdfitError as exc:
        print(f"dpdfit: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"dpdfit: error: {exc.filename or ''}: {exc.strerror or exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
