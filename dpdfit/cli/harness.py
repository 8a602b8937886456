"""``dpdfit harness``: injection-recovery harness of the diagnosis, or external campaigns.

Without ``--campaigns`` it runs :func:`dpdfit.simulation.harness.run_harness`
(simulated campaigns with concealed effects); with ``--campaigns DIR --truth
FILE`` it diagnoses campaigns written elsewhere
(:func:`dpdfit.simulation.harness_external.run_external`).  Both are imported when the
command runs, so that registering its options (``dpdfit --help``) does not load them.
"""

from __future__ import annotations

import argparse
import json

from dpdfit.cli.help_texts import SUMMARIES
from dpdfit.cli.options import nonneg_int, positive_int
from dpdfit.core.defaults import (HARNESS_NULLS, HARNESS_PAIRS, HARNESS_PER_EFFECT,
                                  HARNESS_PER_FORM, HARNESS_SEED, HARNESS_TRIPLES)
from dpdfit.core.jsonable import to_jsonable
from dpdfit.errors import InputError

__all__ = ["add_harness_command", "cmd_harness"]


def cmd_harness(args) -> int:
    """``dpdfit harness``: run the harness (or the external mode) and print its summary."""
    # here, not at the top: --help registers the options without loading the harness
    from dpdfit.simulation.harness import report, run_harness, write_report
    if args.campaigns or args.truth:
        return _cmd_external(args)
    effects = tuple(args.effects.split(",")) if args.effects else None
    s = run_harness(args.per_effect, args.nulls, args.workers, args.scheduler, args.seed,
                    effects, progress=args.progress, log=args.log, pairs=args.pairs,
                    closed_loop=args.closed_loop, triples=args.triples,
                    leave_one_form_out=args.leave_one_form_out, per_form=args.per_form,
                    pairs_left_out=args.pairs_left_out,
                    triples_left_out=args.triples_left_out)
    if args.output:
        write_report(s, args.output)
    if args.json:
        print(json.dumps(to_jsonable({k: v for k, v in s.items() if k != "runs"}), indent=2))
    else:
        print(report(s))
    return 1 if s["n_failed"] else 0        # failed runs are in the report (and the log)


def _cmd_external(args) -> int:
    """``dpdfit harness --campaigns DIR --truth FILE``: diagnose external campaigns
    (:mod:`dpdfit.simulation.harness_external`)."""
    # here, not at the top: --help registers the options without loading the harness
    from dpdfit.simulation.harness import write_report
    from dpdfit.simulation.harness_external import report_external, run_external
    if not (args.campaigns and args.truth):
        raise InputError("--campaigns DIR and --truth FILE go together")
    s = run_external(args.campaigns, args.truth, args.workers, args.scheduler,
                     progress=args.progress)
    if args.output:
        write_report(s, args.output)
    if args.json:
        print(json.dumps(to_jsonable(s), indent=2))
    else:
        print(report_external(s))
    return 0


def add_harness_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit harness [--per-effect 20] [--nulls 20] [--workers N]
    [--scheduler ADDR] [--json]`` on an argparse sub-parsers object (``func=cmd_harness``)."""
    s = subparsers.add_parser(
        "harness", help=SUMMARIES["harness"],
        description="Simulate campaigns with each catalog effect concealed at realistic "
                    "strengths (and pairs and triples of them, and null campaigns), diagnose "
                    "each, and report the confusion matrix, false-alarm rate, recovery of "
                    "each effect's size (pulls and their coverage) and fit improvement. "
                    "--leave-one-form-out also conceals each effect in each of its forms "
                    "and diagnoses it with that form left out of the catalog.")
    s.add_argument("--per-effect", type=nonneg_int, default=HARNESS_PER_EFFECT,
                   help=f"campaigns per effect ({HARNESS_PER_EFFECT})")
    s.add_argument("--nulls", type=nonneg_int, default=HARNESS_NULLS,
                   help=f"campaigns with nothing concealed ({HARNESS_NULLS})")
    s.add_argument("--pairs", type=nonneg_int, default=HARNESS_PAIRS,
                   help="campaigns with two effects concealed at once, random pairs "
                        f"({HARNESS_PAIRS})")
    s.add_argument("--triples", type=nonneg_int, default=HARNESS_TRIPLES,
                   help=f"campaigns with three effects concealed at once ({HARNESS_TRIPLES})")
    s.add_argument("--leave-one-form-out", action="store_true",
                   help="also conceal each effect in each of its forms, diagnosed with that "
                        "form left out of the catalog (--per-form campaigns each)")
    s.add_argument("--per-form", type=positive_int, default=HARNESS_PER_FORM,
                   help=f"campaigns per effect and form with --leave-one-form-out "
                        f"({HARNESS_PER_FORM})")
    s.add_argument("--pairs-left-out", type=nonneg_int, default=0,
                   help="campaigns with two effects at once, each in a form left out of the "
                        "catalog (0)")
    s.add_argument("--triples-left-out", type=nonneg_int, default=0,
                   help="campaigns with three effects at once, each in a form left out of "
                        "the catalog (0)")
    s.add_argument("--workers", type=positive_int, default=None, help="local processes (all cores)")
    s.add_argument("--scheduler", metavar="ADDR", help="dask.distributed scheduler address")
    s.add_argument("--effects", help="comma-separated subset of concealed effects")
    s.add_argument("--seed", type=nonneg_int, default=HARNESS_SEED,
                   help=f"seed of the injection plan ({HARNESS_SEED})")
    s.add_argument("--output", "-o", metavar="FILE.json", help="write the full report (all runs)")
    s.add_argument("--log", metavar="FILE.jsonl",
                   help="append every finished run to this log at once; runs already in it "
                        "are not run again (re-running the command resumes)")
    s.add_argument("--campaigns", metavar="DIR",
                   help="external mode: diagnose every campaign folder in DIR (with --truth)")
    s.add_argument("--truth", metavar="FILE",
                   help="external mode: JSON, campaign id -> {\"effect\": ...}")
    s.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="progress bar on stderr (default: when stderr is a terminal)")
    s.add_argument("--closed-loop", action=argparse.BooleanOptionalAction, default=True,
                   help="for each ambiguous campaign, take the proposed next measurement (and "
                        "a random one from the menu) under the truth and diagnose again "
                        "(default: on)")
    s.add_argument("--json", action="store_true", help="print the summary as JSON")
    s.set_defaults(func=cmd_harness)
    return s
