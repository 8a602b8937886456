"""``dpdfit import``: a lab's ARTIQ results files into a campaign folder, by a mapping.

Also :func:`campaign_argument`, which lets ``analyze`` and ``diagnose`` take a
mapping file in place of a campaign folder (imported into a temporary folder
first).
"""

from __future__ import annotations

import argparse
import contextlib
import shutil
import sys
import tempfile
from pathlib import Path

__all__ = ["add_import_command", "cmd_import", "campaign_argument", "is_mapping",
           "copy_imported"]


def is_mapping(path) -> bool:
    """A mapping file (``*.toml``) rather than a campaign folder."""
    p = Path(path)
    return p.suffix.lower() == ".toml" and not p.is_dir()


@contextlib.contextmanager
def campaign_argument(path, complete_only: bool = False):
    """The campaign folder a command's argument names: the folder itself, or, for a
    mapping file, the campaign imported from it into a temporary folder (removed after)."""
    if not is_mapping(path):
        yield Path(path)
        return
    from dpdfit.recordings.campaign_import import import_campaign
    imported = import_campaign(path, complete_only=complete_only or None)
    with tempfile.TemporaryDirectory(prefix="dpdfit-import-") as tmp:
        folder = imported.write(Path(tmp) / "campaign")
        print(imported.report(), file=sys.stderr)    # stdout may be JSON
        yield folder


def cmd_import(args) -> int:
    from dpdfit.recordings.campaign_import import import_campaign
    imported = import_campaign(args.mapping, complete_only=args.complete_only or None)
    out = imported.write(args.output)
    print(imported.report())
    print(f"wrote campaign {out}")
    return 0


def add_import_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit import`` on an argparse sub-parsers object."""
    c = subparsers.add_parser(
        "import", help="import ARTIQ results files (ndscan scans) into a campaign folder",
        description="Build a campaign folder from a lab's ARTIQ results files, as a TOML "
                    "mapping says (examples/import/*.toml; README 'Importing ARTIQ results "
                    "files').  Every row keeps its source file and rid; campaign.json lists "
                    "the files with their SHA-256.")
    c.add_argument("mapping", metavar="MAP.toml", help="the mapping file")
    c.add_argument("-o", "--output", required=True, metavar="CAMPAIGN_DIR",
                   help="new campaign folder (must not exist, or be empty)")
    c.add_argument("--complete-only", action="store_true",
                   help="skip ndscan scans that did not complete (default: import them "
                        "with a warning)")
    c.set_defaults(func=cmd_import)
    return c


def copy_imported(folder: Path, outdir) -> None:
    """Keep the imported campaign beside the results (``OUTDIR/imported_campaign``)."""
    shutil.copytree(folder, Path(outdir) / "imported_campaign", dirs_exist_ok=True)
