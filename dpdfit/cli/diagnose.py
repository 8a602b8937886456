"""``dpdfit diagnose``: locate simulation/recording mismatches and name the missing physics.

The diagnosis and its figures are imported when the command runs, so that registering
its options (``dpdfit --help``) does not load them.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

from dpdfit.cli.help_texts import SUMMARIES
from dpdfit.cli.options import nonneg_int
from dpdfit.core.defaults import DIAGNOSIS_PAIRS
from dpdfit.core.jsonable import to_jsonable
from dpdfit.errors import InputError
from dpdfit.recordings.outputs import check_output_file, refuse_overwriting_inputs

__all__ = ["add_diagnose_command", "cmd_diagnose"]


def cmd_diagnose(args) -> int:
    """``dpdfit diagnose``: the diagnosis's report (or JSON), warnings on stderr; with
    ``--compare``, what the recordings changed against an earlier diagnosis."""
    # here, not at the top: --help registers the options without loading the diagnosis
    from dpdfit.analyses.diagnosis.comparison.previous import read_diagnosis, refit_request
    from dpdfit.analyses.diagnosis.diagnose import diagnose
    from dpdfit.cli.import_campaign import campaign_argument, is_mapping
    # the earlier diagnosis is read and checked first, and the schedule's path: bad input
    # fails before the fits
    previous = read_diagnosis(args.compare) if args.compare else None
    refit = None if previous is None else refit_request(previous)
    if args.schedule:
        _check_schedule_path(args.schedule, args.campaign)
    with campaign_argument(args.campaign, args.complete_only) as folder:
        res = diagnose(folder, pairs=args.pairs, progress=args.progress,
                       **({"refit": refit} if refit else {}))
        if args.schedule:                 # the grids, phases and times of the campaign
            _write_schedule(res, folder, args.schedule)
    if is_mapping(args.campaign):         # the temporary folder is gone: name the mapping
        res = dataclasses.replace(res, campaign=f"{args.campaign} (imported)")
    comparison = None if previous is None else res.compared_with(previous)
    for w in res.warnings:
        print(f"dpdfit: warning: {w}", file=sys.stderr)
    if args.plot:  # the figures (matplotlib) only when they are asked for
        from dpdfit.report.comparison_plots import comparison_figure
        from dpdfit.report.diagnosis_plots import DIAGNOSIS_DPI, diagnosis_figures
        from dpdfit.report.figure_io import save_figures, use_noninteractive_backend
        use_noninteractive_backend()
        figures = diagnosis_figures(res)
        if comparison is not None:
            figures["diagnosis_comparison"] = comparison_figure(comparison)
        save_figures(figures, args.plot, dpi=DIAGNOSIS_DPI)
    if args.json:
        out = res.to_dict()
        if comparison is not None:
            out["comparison"] = comparison.to_dict()
        print(json.dumps(to_jsonable(out), indent=2))
    else:
        print(res.report() + ("" if comparison is None else "\n\n" + comparison.report()))
    return 0


def _check_schedule_path(path, campaign) -> None:
    """The schedule file can be written, and not into the campaign (never touched)."""
    from dpdfit.cli.import_campaign import is_mapping
    # here, not at the top: --help registers the options without loading the campaign reader
    from dpdfit.recordings.campaign_folder import check_campaign_folder
    if not is_mapping(campaign):           # a link loop or FIFO named before it is resolved
        check_campaign_folder(campaign)
    check_output_file(path, "schedule file")
    refuse_overwriting_inputs([path], [campaign])
    if Path(campaign).is_dir() and Path(campaign).resolve() in Path(path).resolve().parents:
        raise InputError("the schedule file would be written inside the campaign folder, "
                         "which dpdfit never changes; write it elsewhere", file=str(path))


def _write_schedule(res, folder, path) -> None:
    """The proposal as a schedule file, or one line on stderr saying why there is none."""
    if res.proposal is None or res.proposal.what is None:
        why = (res.proposal and res.proposal.reason) or "the diagnosis is not ambiguous"
        print(f"dpdfit: no recording proposed ({why}): no schedule written", file=sys.stderr)
        return
    # here, not at the top: --help registers the options without loading the schedule writer
    from dpdfit.recordings.schedule import write_schedule
    write_schedule(res.schedule(folder), path)


def add_diagnose_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit diagnose CAMPAIGN_DIR [--json] [--plot DIR] [--pairs 3]
    [--compare PREVIOUS_JSON]``."""
    s = subparsers.add_parser(
        "diagnose", help=SUMMARIES["diagnose"],
        description="Standardised residuals of every observable against the simulation built "
                    "from the campaign's own calibration; deviation search with Bonferroni "
                    "correction; every form of each catalog effect fitted and ranked by BIC "
                    "and likelihood-ratio tests; further effects added while decisive; each "
                    "named effect's size in a lab's terms with errors; verdict: the first "
                    "named effect, 'none' or 'unexplained'.")
    s.add_argument("campaign", metavar="CAMPAIGN_DIR",
                   help="campaign folder, or an import mapping (MAP.toml) of ARTIQ results files")
    s.add_argument("--complete-only", action="store_true",
                   help="with a mapping: skip ndscan scans that did not complete")
    s.add_argument("--json", action="store_true", help="print JSON instead of a report")
    s.add_argument("--plot", metavar="DIR", help="write before/after residual plots into DIR")
    s.add_argument("--schedule", metavar="FILE.csv",
                   help="write the proposed next recording as a schedule: one row per point "
                        "and repeat (kind, repeat, point, A, dpd, shots, phase_rad, t_us, "
                        "lab_s, day, start_s, tone_sd_db), for an experiment to loop over")
    s.add_argument("--compare", metavar="PREVIOUS_JSON",
                   help="an earlier diagnosis of this campaign ('dpdfit diagnose --json' "
                        "output) before further recordings were added: refit the pair its "
                        "proposal was to separate and report what the recordings changed "
                        "(verdict, alternatives settled, separation achieved against "
                        "predicted, another recording); --json gains the key 'comparison', "
                        "--plot the figure diagnosis_comparison.png")
    s.add_argument("--pairs", type=nonneg_int, default=DIAGNOSIS_PAIRS,
                   help="after the first effect, try at most this many other effects (the "
                        "best single ones) as an addition at each step; 0: name one effect "
                        f"at most ({DIAGNOSIS_PAIRS})")
    s.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="progress bar on stderr (default: when stderr is a terminal)")
    s.set_defaults(func=cmd_diagnose)
    return s
