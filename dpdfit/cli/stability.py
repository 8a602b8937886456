"""``dpdfit stability``: stability of a multi-run calibration over time (Figs. S1, S2).

The analysis and its figures are imported when the command runs, so that registering its
options (``dpdfit --help``) does not load them.
"""

from __future__ import annotations

import argparse
import json
import sys

from dpdfit.cli.help_texts import SUMMARIES
from dpdfit.cli.options import positive_int, unit_interval
from dpdfit.core.defaults import AMPLITUDE_ORDER, PHASE_MIN_A, PHASE_ORDER
from dpdfit.core.jsonable import to_jsonable
from dpdfit.errors import InputError

__all__ = ["add_stability_command", "cmd_stability"]


def _guess_kind(path) -> str:
    # here, not at the top: --help registers the options without loading the tables
    from dpdfit.recordings.columns import header_columns
    try:
        cols = header_columns(path)    # the header only; a FIFO or device is not opened
    except InputError:                 # unreadable: let stability() report it properly
        return "amplitude"
    if "phase_rad" in cols and "power" not in cols:
        return "phase"
    return "amplitude"


def cmd_stability(args) -> int:
    """``dpdfit stability``: calibration stability over runs (report or JSON)."""
    # here, not at the top: --help registers the options without loading the analysis
    from dpdfit.analyses.stability import stability
    kind = args.kind or _guess_kind(args.file)
    try:
        res = stability(args.file, kind=kind, order=args.order, A_min=args.A_min)
    except InputError as exc:
        for api, opt in (("order must", "--order"), ("phase fit window", "--phase-min-A")):
            if str(exc).startswith(api):
                raise InputError(f"option {opt}: {exc}") from None
        raise
    written = []
    if args.plot:  # the figures (matplotlib) only when they are asked for
        from dpdfit.report.figure_io import save_figures, use_noninteractive_backend
        from dpdfit.report.stability_plots import stability_figures
        use_noninteractive_backend()
        written = save_figures(stability_figures(res), args.plot)
    if args.json:
        d = res.to_dict()
        if written:
            d["figures"] = written
        print(json.dumps(to_jsonable(d), indent=2))
    else:
        print(res.report())
        for p in written:
            print(f"wrote {p}", file=sys.stderr)
    return 0


def add_stability_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit stability runs.csv [--kind amplitude|phase] [--order K]
    [--phase-min-A 0.1] [--json] [--plot DIR]``.

    The registered ``func`` returns 0 and raises
    :class:`~dpdfit.errors.DpdfitError` on bad input.
    """
    s = subparsers.add_parser(
        "stability", help=SUMMARIES["stability"],
        description="Fit every run of a multi-run calibration file and report the time "
                    "series of y(1) = A_corr or phi(1), its mean and scatter, a drift test "
                    "and the Allan deviation (Supplement S2).")
    s.add_argument("file", help="calibration CSV with run, timestamp, A, power|phase_rad columns")
    s.add_argument("--kind", choices=["amplitude", "phase"], default=None,
                   help="amplitude (default) or phase; phase is chosen automatically when "
                        "the file has phase_rad and no power column")
    s.add_argument("--order", type=positive_int, default=None,
                   help=f"polynomial order K ({AMPLITUDE_ORDER} amplitude, {PHASE_ORDER} phase)")
    s.add_argument("--phase-min-A", type=unit_interval, default=PHASE_MIN_A, dest="A_min",
                   help=f"lower end of the phase fit window ({PHASE_MIN_A:g})")
    s.add_argument("--json", action="store_true", help="print the JSON instead of a report")
    s.add_argument("--plot", metavar="DIR", help="write Figs. S1 and S2 (PNG) into DIR")
    s.set_defaults(func=cmd_stability)
    return s
