"""``dpdfit budget``: the error budget of the fidelity offset delta (Table S2).

The analysis is imported when the command runs, so that registering its options
(``dpdfit --help``) does not load it.
"""

from __future__ import annotations

import argparse
import json
import math

from dpdfit.cli.help_texts import SUMMARIES
from dpdfit.cli.options import finite_float, unit_interval
from dpdfit.errors import InputError

__all__ = ["add_budget_command", "cmd_budget"]


def _offset(text: str) -> float:
    """A fidelity offset: a finite number in [-1, 1]."""
    value = finite_float(text)
    if not -1 <= value <= 1:
        raise argparse.ArgumentTypeError(f"must be in [-1, 1], got {value:g}")
    return value


def cmd_budget(args) -> int:
    """``dpdfit budget``: the error budget (report or JSON)."""
    # here, not at the top: --help registers the options without loading the analysis
    from dpdfit.analyses.budget import (error_budget, gate_rates_khz, load_budget_config,
                                        validate_budget_config)
    cfg = load_budget_config(args.config) if args.config else validate_budget_config(None)
    if args.delta is not None:
        cfg["delta"]["value"] = float(args.delta)
        cfg["delta"]["enabled"] = True
    if args.delta_err is not None:
        if not (math.isfinite(args.delta_err) and args.delta_err >= 0):
            raise InputError(f"--delta-err must be >= 0, got {args.delta_err}")
        cfg["delta"]["error"] = float(args.delta_err)
    if args.gate_rates:
        cfg["gate"]["rates_khz"] = gate_rates_khz(args.gate_rates)
    res = error_budget(cfg)
    if args.json:
        print(json.dumps(res.to_dict(), indent=2))
    else:
        print(res.report(paper=not args.no_paper))
    return 0


def add_budget_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit budget [--config F] [--delta D --delta-err E] [--gate-rates CSV]
    [--json]`` on an argparse sub-parsers object (``func=cmd_budget``)."""
    s = subparsers.add_parser(
        "budget", help=SUMMARIES["budget"],
        description="Infidelity contributions of state preparation, dephasing, heating and "
                    "detection with Monte-Carlo uncertainties, compared with the fitted "
                    "offset delta (Supplement S10, Table S2).")
    s.add_argument("--config", help="budget TOML file (all keys optional; see dpdfit.analyses.budget)")
    s.add_argument("--delta", type=_offset, help="fitted fidelity offset delta (e.g. -0.018)")
    s.add_argument("--delta-err", type=unit_interval, help="1-sigma error of delta (e.g. 0.003)")
    s.add_argument("--gate-rates", metavar="CSV",
                   help="gate rates (columns A, dpd, xi0_khz): gate times 1/xi0")
    s.add_argument("--no-paper", action="store_true", help="report without the paper column")
    s.add_argument("--json", action="store_true", help="print the JSON instead of a report")
    s.set_defaults(func=cmd_budget)
    return s
