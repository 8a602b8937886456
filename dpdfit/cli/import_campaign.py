"""``dpdfit import``: a lab's ARTIQ results files into a campaign folder, by a mapping.

Also :func:`campaign_argument`, which lets ``analyze`` and ``diagnose`` take a
mapping file in place of a campaign folder (``analyze`` imports it into its
results folder, ``diagnose`` into a temporary folder).
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import os
import sys
import tempfile
from pathlib import Path

from dpdfit.cli.help_texts import SUMMARIES
from dpdfit.errors import InputError
from dpdfit.recordings.input_files import read_input_json
from dpdfit.recordings.outputs import folder_made

__all__ = ["add_import_command", "cmd_import", "campaign_argument", "is_mapping",
           "add_write_artiq_results_command", "cmd_write_artiq_results"]

log = logging.getLogger(__name__)


def is_mapping(path) -> bool:
    """A mapping file (``*.toml``) rather than a campaign folder."""
    p = Path(path)
    return p.suffix.lower() == ".toml" and not p.is_dir()


@contextlib.contextmanager
def campaign_argument(path, complete_only: bool = False, keep_in=None):
    """The campaign folder a command's argument names: the folder itself, or, for a
    mapping file, the campaign imported from it -- into ``keep_in/imported_campaign``
    when given (an earlier import there is replaced; anything else is refused), else
    into a temporary folder removed afterwards.  A folder is checked first
    (:func:`~dpdfit.recordings.campaign_folder.check_campaign_folder`): a symbolic link
    loop, a FIFO or a folder that cannot be read is one InputError naming it."""
    if not is_mapping(path):
        from dpdfit.recordings.campaign_folder import check_campaign_folder
        yield check_campaign_folder(path)
        return
    from dpdfit.recordings.campaign_import import import_campaign
    imported = import_campaign(path, complete_only=complete_only or None)
    if keep_in is None:
        with tempfile.TemporaryDirectory(prefix="dpdfit-import-") as tmp:
            folder = imported.write(Path(tmp) / "campaign")
            _tell(imported, sys.stderr)                  # stdout may be JSON
            yield folder
        return
    target = Path(keep_in) / "imported_campaign"
    if target.exists() and not _imported_before(target):
        raise InputError("exists and is not a campaign dpdfit imported: not replaced",
                         file=str(target))
    # a refused import leaves nothing, not even the folders made for it
    with folder_made(keep_in), \
            tempfile.TemporaryDirectory(prefix=".imported_campaign.", dir=keep_in) as tmp:
        new = imported.write(Path(tmp) / "campaign")
        if target.exists():
            os.replace(target, Path(tmp) / "previous")
        os.replace(new, target)
    _tell(imported, sys.stderr)
    yield target


def _tell(imported, out) -> None:
    """What was imported (to ``out``), then each warning once, on stderr: only once
    the campaign is written, so that an error is never preceded by warnings."""
    print(imported.report(notes=False), file=out)
    for note in imported.notes():
        log.warning("%s", note)


def _imported_before(folder: Path) -> bool:
    try:
        # a regular file inside the folder: a FIFO put there is refused, not read
        meta = read_input_json(folder / "campaign.json", within=folder, what="campaign.json")
    except InputError:
        return False
    return isinstance(meta, dict) and "imported" in meta


def cmd_import(args) -> int:
    """``dpdfit import``: build a campaign folder from ARTIQ results files as a mapping
    says; prints what was imported."""
    from dpdfit.recordings.campaign_import import import_campaign
    imported = import_campaign(args.mapping, complete_only=args.complete_only or None,
                               progress=args.progress,
                               skip_bad_files=args.skip_bad_files or None)
    out = imported.write(args.output)
    _tell(imported, sys.stdout)
    print(f"wrote campaign {out}")
    return 0


def add_import_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit import`` on an argparse sub-parsers object."""
    c = subparsers.add_parser(
        "import", help=SUMMARIES["import"],
        description="Build a campaign folder from a lab's ARTIQ results files, as a TOML "
                    "mapping says (the .toml files in examples/import; the documentation's "
                    "guide page on importing lab recordings).  Every row keeps its source file and rid; "
                    "campaign.json lists the files with their SHA-256.")
    c.add_argument("mapping", metavar="MAP.toml", help="the mapping file")
    c.add_argument("-o", "--output", required=True, metavar="CAMPAIGN_DIR",
                   help="new campaign folder (must not exist, or be empty)")
    c.add_argument("--complete-only", action="store_true",
                   help="skip ndscan scans that did not complete (default: import them "
                        "with a warning)")
    c.add_argument("--skip-bad-files", action="store_true",
                   help="skip a results file that cannot be read or mapped (an aborted "
                        "run), with a warning each (default: it stops the import)")
    c.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="progress bar over the results files on stderr (default: when "
                        "stderr is a terminal)")
    c.set_defaults(func=cmd_import)
    return c


def cmd_write_artiq_results(args) -> int:
    """``dpdfit write-artiq-results``: a campaign folder as ARTIQ results files plus
    the mapping that imports them back."""
    from dpdfit.simulation.artiq_results import write_ndscan_campaign, write_per_shot_campaign
    if args.schedule is not None:
        return _write_schedule_results(args)
    if args.out_dir.exists() and any(args.out_dir.iterdir()):
        raise InputError("exists and is not empty (the mapping's globs would pick up its "
                         "old files); choose a new folder", file=str(args.out_dir))
    if args.shape == "ndscan":
        mapping = write_ndscan_campaign(args.campaign_dir, args.out_dir)
    else:
        mapping = write_per_shot_campaign(args.campaign_dir, args.out_dir, seed=args.seed)
    files = sorted(args.out_dir.glob("results/*/*/*.h5"))
    print(f"wrote {len(files)} results files and {mapping}")
    return 0


def _write_schedule_results(args) -> int:
    """``--schedule``: the simulator records the schedule; only the new files are written."""
    from dpdfit.simulation.recorded_artiq import record_schedule
    if args.shape != "ndscan":
        raise InputError("--schedule writes the ndscan layout only (leave out --shape "
                         f"{args.shape})")
    rec = record_schedule(args.campaign_dir, args.schedule, args.out_dir)
    files = sorted(args.out_dir.glob("results/*/*/*.h5"))
    rows = ", ".join(f"{n} {t}" for t, n in rec.rows().items())
    print(f"recorded {rows} rows; wrote {len(files)} results files and "
          f"{args.out_dir / 'mapping.toml'}")
    return 0


def add_write_artiq_results_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit write-artiq-results`` on an argparse sub-parsers object."""
    c = subparsers.add_parser(
        "write-artiq-results", help=SUMMARIES["write-artiq-results"],
        description="Write a campaign folder's tables as the HDF5 results files an ARTIQ "
                    "master and ndscan write (results/<date>/<hour>/<rid>-<Class>.h5), "
                    "together with OUT_DIR/mapping.toml, which imports them back.  "
                    "--shape ndscan: every table as ndscan scans (imported back bit for "
                    "bit); per-shot: per-shot outcome arrays, phases in turns, plain "
                    "datasets, an old-ndscan file and an interrupted scan.  With --schedule "
                    "the simulator stands in for the lab: a simulated campaign (with its "
                    "truth.json) records the schedule's points, and only those new "
                    "recordings are written, numbered after the campaign's, with a mapping "
                    "that imports them for adding to a copy of the campaign.  Needs h5py.")
    c.add_argument("campaign_dir", type=Path, metavar="CAMPAIGN_DIR")
    c.add_argument("out_dir", type=Path, metavar="OUT_DIR",
                   help="new folder for results/ and mapping.toml")
    c.add_argument("--shape", choices=("ndscan", "per-shot"), default="ndscan",
                   help="layout of the files (default: ndscan)")
    c.add_argument("--seed", type=int, default=0, help="seed of the per-shot outcomes (0)")
    c.add_argument("--schedule", type=Path, metavar="SCHEDULE.csv", default=None,
                   help="record this schedule (dpdfit diagnose --schedule) under the "
                        "campaign's truth.json and write only the new recordings")
    c.set_defaults(func=cmd_write_artiq_results)
    return c
