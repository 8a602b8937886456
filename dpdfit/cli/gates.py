"""``dpdfit fidelity`` and ``dpdfit align``: the measured gate side (S6.3-S6.4, S7).

``fidelity`` infers Bell fidelities from raw population and parity counts;
``align`` fits the scale ``alpha`` and offset ``delta`` that put the
photodiode curves of a sweep onto the gate data.

The fits and readers are imported by the functions that run the commands, so that
registering the commands' options (``dpdfit --help``) does not load them.
"""

from __future__ import annotations

import argparse
import json
import sys

from dpdfit.cli.help_texts import SUMMARIES
from dpdfit.cli.options import positive_float
from dpdfit.core.defaults import ERROR_MODEL
from dpdfit.core.jsonable import to_jsonable
from dpdfit.recordings.outputs import refuse_overwriting_inputs

__all__ = ["add_fidelity_command", "add_align_command", "cmd_fidelity", "cmd_align"]


# ----------------------------------------------------------------------------- fidelity


def _gate_table(pop_path, par_path, interval, rates_path=None):
    # here, not at the top: --help registers the options without loading the fits
    from dpdfit.fits.counts import gate_fidelities
    from dpdfit.recordings.counts import read_parity, read_populations
    from dpdfit.recordings.gate_rates import read_gate_rates
    # read (and validated) first, by the campaign's own reader: before the count files'
    # fits and warnings
    rates = read_gate_rates(rates_path) if rates_path else None
    pop = read_populations(pop_path)
    par = read_parity(par_path)
    tab = gate_fidelities(pop, par, interval=interval)
    if rates is not None:
        cols = ["A", "dpd", "xi0_khz"] + (["xi0_err_khz"] if "xi0_err_khz" in rates else [])
        tab = tab.merge(rates[cols], on=["A", "dpd"], how="left")
    return tab


def _print_gate_table(records) -> None:
    print(f"{'A':>6s} {'dpd':>3s} {'F_pop':>9s} {'+/-':>7s} {'F_par':>9s} {'+/-':>7s} "
          f"{'F':>9s} {'+/-':>7s} {'scans':>5s} {'shots':>6s}")
    for r in records:
        print(f"{r['A']:6.3f} {int(r['dpd']):3d} {r['F_pop']:9.5f} {r['F_pop_err']:7.5f} "
              f"{r['F_par']:9.5f} {r['F_par_err']:7.5f} {r['F']:9.5f} {r['F_err']:7.5f} "
              f"{int(r['n_scans']):5d} {int(r['shots']):6d}")


def cmd_fidelity(args) -> int:
    """``dpdfit fidelity``: Bell fidelities per setting from raw population and parity
    counts (table or JSON; ``-o`` writes the CSV, ``--plot`` the parity fringes)."""
    outs = [args.output] if args.output else []
    refuse_overwriting_inputs(outs, [args.populations, args.parity, args.gate_rates])
    tab = _gate_table(args.populations, args.parity, args.interval, args.gate_rates)
    records = tab.to_dict(orient="records")
    if args.output:
        from dpdfit.recordings.outputs import atomic_write_text, csv_table_text
        atomic_write_text(args.output, csv_table_text(tab, args.output, float_format="%.10g"))
    if args.json:
        print(json.dumps(to_jsonable(records), indent=2))
    else:
        _print_gate_table(records)
    if args.plot:
        from dpdfit.fits.counts import merge_parity
        from dpdfit.recordings.counts import read_parity
        from dpdfit.report.figure_io import save_figures, use_noninteractive_backend
        from dpdfit.report.gate_plots import merged_parity_figure
        use_noninteractive_backend()
        par = merge_parity(read_parity(args.parity))
        fig = merged_parity_figure(tab, par)
        for p in save_figures({"figS7_parity_fringes": fig}, args.plot):
            print(f"wrote {p}", file=sys.stderr)
    if args.output:
        print(f"wrote {args.output}", file=sys.stderr)
    return 0


def add_fidelity_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit fidelity`` on an argparse sub-parsers object."""
    f = subparsers.add_parser("fidelity",
                              help=SUMMARIES["fidelity"])
    f.add_argument("--populations", required=True, metavar="POP.csv",
                   help="A, dpd, scan, n_even, shots (or n00, n01_10, n11, shots)")
    f.add_argument("--parity", required=True, metavar="PARITY.csv",
                   help="A, dpd, scan, phase_rad, n_even, shots")
    f.add_argument("--interval", choices=["wilson", "clopper-pearson"], default="wilson",
                   help="population interval near 1 (wilson)")
    f.add_argument("--gate-rates", metavar="RATES.csv",
                   help="A, dpd, xi0_khz (+ xi0_err_khz): joined into -o")
    f.add_argument("-o", "--output", metavar="GATE.csv", help="write the table as CSV")
    f.add_argument("--json", action="store_true",
                   help="print a JSON list (one record per A, dpd)")
    f.add_argument("--plot", metavar="DIR", help="write the parity-fringe figure (Fig. S7)")
    f.set_defaults(func=cmd_fidelity)
    return f


# ----------------------------------------------------------------------------- align


def _sigma_db(text: str) -> float:
    """Laser-power fluctuation (1 sigma, dB): a finite number in (0, 10]."""
    value = positive_float(text)
    if value > 10:
        raise argparse.ArgumentTypeError(f"must be in (0, 10] dB, got {value:g}")
    return value


def cmd_align(args) -> int:
    """``dpdfit align``: fit the scale ``alpha`` (kHz) and offset ``delta`` that put a
    sweep's photodiode curves onto the gate table (report or JSON, ``--plot`` the figures)."""
    # here, not at the top: --help registers the options without loading the fits
    from dpdfit.analyses.sweep import read_sweep_table
    from dpdfit.fits.alignment import align
    from dpdfit.recordings.tables import read_table
    # xi0_err_khz is optional, as in gate_rates.csv: 'fidelity' leaves it out without it
    gate = read_table(args.gate, ["A", "dpd", "xi0_khz", "F", "F_err"], ["xi0_err_khz"],
                      numeric=["A", "dpd", "xi0_khz", "xi0_err_khz", "F", "F_err"],
                      ranges={"A": (0.0, 1.0), "dpd": (0, 1), "F": (0.0, 1.0)},
                      positive=["xi0_khz"], unique=["A", "dpd"])
    sweep = read_sweep_table(args.sweep)
    fit = align(gate, sweep, args.sigma_db)
    if args.json:
        print(json.dumps(to_jsonable(fit.to_dict()), indent=2))
    else:
        print(fit.report())
    if args.plot:
        from dpdfit.report.figure_io import save_figures, use_noninteractive_backend
        from dpdfit.report.gate_plots import gate_figures
        use_noninteractive_backend()
        for p in save_figures(gate_figures(gate.copy(), sweep, fit), args.plot):
            print(f"wrote {p}", file=sys.stderr)
    return 0


def add_align_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit align`` on an argparse sub-parsers object."""
    al = subparsers.add_parser(
        "align", help=SUMMARIES["align"])
    al.add_argument("--gate", required=True,
                    help="A, dpd, xi0_khz, F, F_err (+ xi0_err_khz), e.g. from 'fidelity -o'")
    al.add_argument("--sweep", required=True, help="sweep.csv from 'dpdfit sweep'")
    al.add_argument("--sigma-db", type=_sigma_db, default=ERROR_MODEL.power_jitter_db,
                    help=f"laser-power fluctuation, dB ({ERROR_MODEL.power_jitter_db:g})")
    al.add_argument("--json", action="store_true")
    al.add_argument("--plot", metavar="DIR", help="write Figs. 3 and 4 (PNG)")
    al.set_defaults(func=cmd_align)
    return al
