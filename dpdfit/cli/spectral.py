"""``dpdfit sweep``, ``estimate``, ``im-table`` and ``thresholds``: the spectral side (S5, S6).

``sweep`` simulates the amplitude sweep of a calibration; ``estimate`` is the
closed-form fidelity estimate from one sideband's tone powers; ``im-table``
prints the required gate-to-IM power ratios (Table S1); ``thresholds`` reads a
sweep table back and prints its threshold efficiencies.

The models and analyses are imported by the functions that run the commands, so that
registering the commands' options (``dpdfit --help``) does not load them.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from dpdfit.cli.help_texts import SUMMARIES
from dpdfit.cli.options import fraction, nonneg_float, positive_float
from dpdfit.core.defaults import ETA_REF, FORMULA, FORMULAS, NBAR, NU_HZ, XI0_SPECTRA_HZ
from dpdfit.core.version import __version__
from dpdfit.errors import InputError
from dpdfit.recordings.outputs import (refuse_overwriting_inputs, sha256_file,
                                       to_jsonable, write_csv_with_header)

__all__ = ["add_sweep_command", "add_estimate_command", "add_im_table_command",
           "add_thresholds_command", "cmd_sweep", "cmd_estimate", "cmd_im_table",
           "cmd_thresholds"]


def _eta_corr_line(th: dict) -> str:
    """``eta_bar_corr`` in the report at the precision of its meaning (JSON keeps every
    digit): the 12th digit moves with the BLAS build, and a reader cannot use it."""
    v = {k: "-" if th["eta_corr"][k] is None else f"{th['eta_corr'][k]:.6f}"
         for k in ("dpd", "no_dpd")}
    return f"eta_bar_corr: DPD {v['dpd']}, no DPD {v['no_dpd']}"


def _print_thresholds(th: dict) -> None:
    for key in ("no_dpd", "dpd"):
        print(f"eta_th ({key}): " + ", ".join(
            f"{lev}: {'-' if v is None else f'{v:.4f}'}" for lev, v in th["eta_th"][key].items()))


# ----------------------------------------------------------------------------- sweep


def _float_arg(name, value, positive=True):
    if value is None or not np.isfinite(value) or (positive and value <= 0):
        raise InputError(f"{name} must be a positive number, got {value}")
    return float(value)


def cmd_sweep(args) -> int:
    """``dpdfit sweep``: simulate the amplitude sweep of a calibration (spectra, F_est,
    eta_bar, r_rel per amplitude and DPD flag) into a CSV table; prints the threshold
    efficiencies."""
    # here, not at the top: --help registers the options without loading the models
    from dpdfit.analyses.sweep import (SweepConfig, check_sweep_size, parse_amplitudes,
                                       run_sweep, thresholds)
    from dpdfit.fits.calibration import load_calibration
    from dpdfit.models.transfer import TransferFunction
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
    check_sweep_size(cfg, names=("option --nu", "--xi0", "--amplitudes points"))
    df = run_sweep(tf, cfg)
    th = thresholds(df)
    meta = {"dpdfit_version": __version__,
            "calibration_file": str(args.calibration),
            "calibration_sha256": sha256_file(args.calibration),
            **{k: v for k, v in df.attrs.items()}}
    figures = {}
    if args.plot:  # drawn before anything is written: a failing figure writes nothing
        from dpdfit.report.figure_io import use_noninteractive_backend
        from dpdfit.report.sweep_plots import sweep_figures
        use_noninteractive_backend()
        figures = sweep_figures(df)
    write_csv_with_header(out, df, meta)
    print(f"sweep: {len(cfg.amplitudes)} amplitudes x 2 DPD flags x 3 rows "
          f"({'AM only' if cfg.am_only else 'AM+PM'}, formula {cfg.formula}, nbar {cfg.nbar:g})")
    print(f"A_corr = {tf.A_corr:.6f}; {_eta_corr_line(th)}")
    _print_thresholds(th)
    print(f"wrote {out}", file=sys.stderr)
    if figures:
        from dpdfit.report.figure_io import save_figures
        for p in save_figures(figures, args.plot):
            print(f"wrote {p}", file=sys.stderr)
    return 0


def add_sweep_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit sweep`` on an argparse sub-parsers object."""
    w = subparsers.add_parser("sweep", help=SUMMARIES["sweep"])
    w.add_argument("calibration", help="calibration.json")
    w.add_argument("--amplitudes", metavar="START:STOP:N",
                   help="inclusive amplitude grid (default 0.05:1:100)")
    w.add_argument("--nbar", type=nonneg_float, default=NBAR, help=f"thermal phonon number ({NBAR:g})")
    w.add_argument("--am-only", action="store_true", help="forward model without AM-to-PM")
    w.add_argument("--xi0", type=positive_float, default=XI0_SPECTRA_HZ, help="gate detuning, Hz (20e3)")
    w.add_argument("--nu", type=positive_float, default=NU_HZ, help="sideband detuning, Hz (1.84e6)")
    w.add_argument("--formula", choices=FORMULAS, default=FORMULA,
                   help=f"Bell-fidelity expression (default {FORMULA}; see the documentation's spectra guide)")
    w.add_argument("--eta-ref", type=fraction, default=ETA_REF,
                   help=f"peak diffraction efficiency ({ETA_REF:.2f})")
    w.add_argument("--anchor-A", type=fraction, default=0.4, help="r_rel anchor amplitude (0.4)")
    w.add_argument("--anchor-dpd", type=int, choices=[0, 1], default=0,
                   help="r_rel anchor DPD flag (0)")
    w.add_argument("-o", "--output", required=True, help="sweep table (CSV)")
    w.add_argument("--plot", metavar="DIR", help="write Figs. 2, 5, S3, S5 (PNG) into DIR")
    w.set_defaults(func=cmd_sweep)
    return w


# ----------------------------------------------------------------------------- estimate


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
    """``dpdfit estimate``: closed-form Bell-fidelity estimate F_est from one
    sideband's tone powers (dB per harmonic); refuses a non-finite estimate."""
    # here, not at the top: --help registers the options without loading the models
    from dpdfit.models.fidelity import estimate
    harm, P = _parse_powers_db(args.powers_db)
    with np.errstate(all="ignore"):      # a non-finite estimate is refused below
        est = estimate(P, harm, nbar=args.nbar, formula=args.formula)
    d = est.to_dict()
    if not all(np.isfinite(d[k]) for k in ("F_est", "eps_est", "F", "G", "Phi")):
        raise InputError(f"--powers-db: no finite estimate from '{args.powers_db}' (gate tones "
                         "too weak for the other tones' powers?)")
    if args.json:
        print(json.dumps(to_jsonable(d), indent=2))
    else:
        print(f"F_est   = {d['F_est']:.9f}   eps_est = {d['eps_est']:.3e}   "
              f"(formula {args.formula}, nbar {args.nbar:g})")
        print(f"F(T_g)  = {d['F']:+.6e}   G(T_g) = {d['G']:+.6e}   Phi(T_g) = {d['Phi']:.9f} rad")
    return 0


def add_estimate_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit estimate`` on an argparse sub-parsers object."""
    e = subparsers.add_parser("estimate",
                              help=SUMMARIES["estimate"])
    e.add_argument("--powers-db", required=True, metavar="n:dB,...",
                   help='tone powers, e.g. "0:-40,1:0,2:0,3:-30"')
    e.add_argument("--nbar", type=nonneg_float, default=NBAR, help=f"thermal phonon number ({NBAR:g})")
    e.add_argument("--formula", choices=FORMULAS, default=FORMULA)
    e.add_argument("--json", action="store_true")
    e.set_defaults(func=cmd_estimate)
    return e


# ----------------------------------------------------------------------------- im-table


def cmd_im_table(args) -> int:
    """``dpdfit im-table``: the required gate-to-IM power ratios (dB) per infidelity
    level, for an IM tone at harmonic n = 0 or n = 3 (Table S1; report or JSON)."""
    # here, not at the top: --help registers the options without loading the models
    from dpdfit.models.im_requirements import im_requirements
    tab = im_requirements(nbar=args.nbar, formula=args.formula, as_printed=args.as_printed)
    if args.json:
        print(json.dumps(to_jsonable(tab), indent=2))
    else:
        what = ("as printed in Table S1 (assumptions: see the documentation's spectra guide)" if args.as_printed
                else f"formula {args.formula}, nbar {args.nbar:g}")
        print(f"required P_gate/P_IM (dB), {what}")
        print("  infidelity      n=0       n=3")
        for lev in tab["0"]:
            v0, v3 = tab["0"][lev], tab["3"][lev]
            print(f"  {lev:>10s}  {v0:8.2f}  {v3:8.2f}")
    return 0


def add_im_table_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit im-table`` on an argparse sub-parsers object."""
    m = subparsers.add_parser("im-table", help=SUMMARIES["im-table"])
    m.add_argument("--nbar", type=nonneg_float, default=NBAR, help=f"thermal phonon number ({NBAR:g})")
    m.add_argument("--formula", choices=FORMULAS, default=FORMULA)
    m.add_argument("--as-printed", action="store_true",
                   help="use the assumptions that reproduce the printed Table S1")
    m.add_argument("--json", action="store_true")
    m.set_defaults(func=cmd_im_table)
    return m


# ----------------------------------------------------------------------------- thresholds


def cmd_thresholds(args) -> int:
    """``dpdfit thresholds``: ``eta_bar_corr`` and the threshold efficiencies of a sweep
    table (``A_corr`` from its header, or ``--A-corr``)."""
    # here, not at the top: --help registers the options without loading the analyses
    from dpdfit.analyses.sweep import read_sweep_table, thresholds
    df = read_sweep_table(args.sweep)
    A_corr = args.A_corr if args.A_corr is not None else df.attrs.get("A_corr")
    if A_corr is None:
        raise InputError("no A_corr in the sweep file's header; give --A-corr", file=str(args.sweep))
    df.attrs["A_corr"] = float(A_corr)
    res = thresholds(df)
    if args.json:
        print(json.dumps(to_jsonable(res), indent=2))
    else:
        print(_eta_corr_line(res))
        _print_thresholds(res)
    return 0


def add_thresholds_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit thresholds`` on an argparse sub-parsers object."""
    h = subparsers.add_parser("thresholds",
                              help=SUMMARIES["thresholds"])
    h.add_argument("sweep", help="sweep.csv written by 'dpdfit sweep'")
    h.add_argument("--A-corr", type=fraction, dest="A_corr",
                   help="A_corr if the sweep file's header lacks it")
    h.add_argument("--json", action="store_true")
    h.set_defaults(func=cmd_thresholds)
    return h
