"""``dpdfit simulate-campaign`` and ``dpdfit analyze``: whole campaign folders.

``simulate-campaign`` writes a synthetic measurement campaign (optionally with
concealed effects); ``analyze`` runs every analysis on a campaign folder
(:func:`dpdfit.pipeline.analyze.analyze`) and exits with status 2 when any
analysis failed.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from dpdfit.cli.help_texts import SUMMARIES
from dpdfit.cli.options import nonneg_int
from dpdfit.core.defaults import ERROR_MODEL, FORMULA

__all__ = ["add_simulate_campaign_command", "add_analyze_command", "cmd_simulate_campaign",
           "cmd_analyze"]


def cmd_simulate_campaign(args) -> int:
    """``dpdfit simulate-campaign``: write a synthetic campaign folder (seeded,
    optionally with concealed effects)."""
    from dpdfit.simulation.campaign import CampaignConfig, parse_effects, simulate_campaign
    effects = parse_effects(args.effects)
    cfg = CampaignConfig(seed=args.seed, stale_days=args.stale_days,
                         table_drift=args.table_drift)
    simulate_campaign(args.outdir, seed=args.seed, effects=effects, config=cfg,
                      progress=args.progress)
    print(f"wrote campaign {args.outdir} (seed {args.seed}"
          + (f", effects {args.effects}" if effects else "") + ")")
    return 0


def _effects_help() -> str:
    """``name (unit), ...`` of the registered effects' strengths."""
    from dpdfit.simulation.campaign import SIMULATOR_EFFECTS
    return ", ".join(f"{n} ({u})" for n, (u, _) in SIMULATOR_EFFECTS.items())


def add_simulate_campaign_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit simulate-campaign`` on an argparse sub-parsers object."""
    c = subparsers.add_parser("simulate-campaign",
                              help=SUMMARIES["simulate-campaign"])
    c.add_argument("outdir", help="new folder to write the campaign into")
    c.add_argument("--seed", type=nonneg_int, default=ERROR_MODEL.seed,
                   help=f"random seed ({ERROR_MODEL.seed})")
    c.add_argument("--effects", metavar="NAME=STRENGTH,...",
                   help="effects to conceal, each a registered effect of the diagnosis's "
                        "catalog: NAME=STRENGTH sets its strength, NAME.PARAM=VALUE "
                        f"another of its parameters ({_effects_help()})")
    c.add_argument("--stale-days", type=float, default=0.0, metavar="DAYS",
                   help="the predistortion table comes from the calibration run this many "
                        "days before the gate day (0)")
    c.add_argument("--table-drift", type=float, default=0.0, metavar="FRACTION",
                   help="the table comes from an unrecorded calibration of the AOM whose "
                        "A_corr was this fraction off the table run's (0)")
    c.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="progress bars on stderr (default: when stderr is a terminal)")
    c.set_defaults(func=cmd_simulate_campaign)
    return c


def cmd_analyze(args) -> int:
    """``dpdfit analyze``: every analysis of a campaign folder (or of an import
    mapping) into a results folder; prints one status line per analysis and exits
    with 2 if any analysis failed."""
    from dpdfit.pipeline.analyze import analyze
    if not args.no_plots:
        from dpdfit.report.figure_io import use_noninteractive_backend
        use_noninteractive_backend()
    from dpdfit.cli.import_campaign import campaign_argument
    out = Path(args.output)
    # a mapping is imported into the results folder: the results name their inputs
    with campaign_argument(args.folder, args.complete_only, keep_in=out) as folder:
        res = analyze(folder, out, formula=args.formula, plots=not args.no_plots,
                      diagnosis=not args.no_diagnosis, progress=args.progress)
    for name, st in res.summary["analyses"].items():
        print(f"{name:12s} {st['status']:8s} {st['detail']}")
    print(f"results in {out}/ (summary.md, summary.json)")
    return 2 if res.failures else 0


def add_analyze_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit analyze`` on an argparse sub-parsers object."""
    a = subparsers.add_parser("analyze",
                              help=SUMMARIES["analyze"])
    a.add_argument("folder", help="campaign folder (campaign.json, calibration_*.csv, ...), "
                   "or an import mapping (MAP.toml) of ARTIQ results files")
    a.add_argument("--complete-only", action="store_true",
                   help="with a mapping: skip ndscan scans that did not complete")
    a.add_argument("-o", "--output", required=True, help="results folder")
    a.add_argument("--formula", choices=["exact", "paper"], default=FORMULA,
                   help=f"Bell-fidelity expression for F_est ({FORMULA})")
    a.add_argument("--no-plots", action="store_true", help="skip the figures")
    a.add_argument("--no-diagnosis", action="store_true",
                   help="skip the discrepancy diagnosis (the slowest step)")
    a.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="progress bar on stderr (default: when stderr is a terminal)")
    a.set_defaults(func=cmd_analyze)
    return a
