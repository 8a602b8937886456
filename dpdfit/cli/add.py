"""``dpdfit add``: further recordings merged into a copy of a campaign folder.

A thin layer over :func:`dpdfit.recordings.campaign_add.add_recordings`: the output
folder is checked before anything is read, the merged campaign is written (read back
first), then the report is printed.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from dpdfit.cli.help_texts import SUMMARIES
from dpdfit.cli.import_campaign import is_mapping

__all__ = ["add_add_command", "cmd_add"]


def cmd_add(args) -> int:
    """``dpdfit add CAMPAIGN NEW -o OUT``: write OUT, the campaign with NEW's recordings."""
    from dpdfit.recordings.add_checks import check_output
    from dpdfit.recordings.campaign_add import add_recordings
    check_output(args.output, args.campaign, args.new, not is_mapping(args.new))
    added = add_recordings(args.campaign, args.new, complete_only=args.complete_only or None,
                           progress=args.progress, skip_bad_files=args.skip_bad_files or None)
    out = added.write(args.output)
    print(added.report())
    print(f"wrote campaign {out}")
    return 0


def add_add_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit add`` on an argparse sub-parsers object."""
    c = subparsers.add_parser(
        "add", help=SUMMARIES["add"],
        description="Write a new campaign folder: CAMPAIGN's recordings, unchanged, and "
                    "NEW's appended -- NEW a folder of CSV files in the campaign layout (any "
                    "of the tables) or an import mapping of ARTIQ results files, read as "
                    "'dpdfit import' reads it.  Scan labels and spectra repeats continue, a "
                    "calibration run already there is skipped, and campaign.json's new key "
                    "'added' records where each added row came from and when.  Of CAMPAIGN's "
                    "other files only those of the campaign layout are copied (README.md, "
                    "budget.toml, traces.csv and the traces it names), each a regular file "
                    "inside CAMPAIGN; any other is left out and named in the report, and a "
                    "link out of CAMPAIGN or NEW is refused.  CAMPAIGN is "
                    "never written; recordings of another campaign (nu_hz, predistortion "
                    "table, ion setup) are refused.")
    c.add_argument("campaign", type=Path, metavar="CAMPAIGN", help="the campaign folder")
    c.add_argument("new", type=Path, metavar="NEW",
                   help="folder of CSV files, or an import mapping (.toml)")
    c.add_argument("-o", "--output", required=True, type=Path, metavar="OUT",
                   help="the new campaign folder (must not exist)")
    c.add_argument("--complete-only", action="store_true",
                   help="NEW a mapping: skip ndscan scans that did not complete")
    c.add_argument("--skip-bad-files", action="store_true",
                   help="NEW a mapping: skip a results file that cannot be read or mapped, "
                        "with a warning each")
    c.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="NEW a mapping: progress bar over the results files on stderr "
                        "(default: when stderr is a terminal)")
    c.set_defaults(func=cmd_add)
    return c
