"""``dpdfit import``: a lab's ARTIQ results files into a campaign folder, by a mapping.

Also :func:`campaign_argument`, which lets ``analyze`` and ``diagnose`` take a
mapping file in place of a campaign folder (``analyze`` imports it into its
results folder, ``diagnose`` into a temporary folder).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import tempfile
from pathlib import Path

from dpdfit.errors import InputError

__all__ = ["add_import_command", "cmd_import", "campaign_argument", "is_mapping"]


def is_mapping(path) -> bool:
    """A mapping file (``*.toml``) rather than a campaign folder."""
    p = Path(path)
    return p.suffix.lower() == ".toml" and not p.is_dir()


@contextlib.contextmanager
def campaign_argument(path, complete_only: bool = False, keep_in=None):
    """The campaign folder a command's argument names: the folder itself, or, for a
    mapping file, the campaign imported from it -- into ``keep_in/imported_campaign``
    when given (an earlier import there is replaced; anything else is refused), else
    into a temporary folder removed afterwards."""
    if not is_mapping(path):
        yield Path(path)
        return
    from dpdfit.recordings.campaign_import import import_campaign
    imported = import_campaign(path, complete_only=complete_only or None)
    if keep_in is None:
        with tempfile.TemporaryDirectory(prefix="dpdfit-import-") as tmp:
            folder = imported.write(Path(tmp) / "campaign")
            print(imported.report(), file=sys.stderr)    # stdout may be JSON
            yield folder
        return
    target = Path(keep_in) / "imported_campaign"
    if target.exists() and not _imported_before(target):
        raise InputError("exists and is not a campaign dpdfit imported: not replaced",
                         file=str(target))
    Path(keep_in).mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix=".imported_campaign.", dir=keep_in) as tmp:
        new = imported.write(Path(tmp) / "campaign")
        if target.exists():
            new_old = Path(tmp) / "previous"
            os.replace(target, new_old)
        os.replace(new, target)
    print(imported.report(), file=sys.stderr)
    yield target


def _imported_before(folder: Path) -> bool:
    try:
        return "imported" in json.loads((folder / "campaign.json").read_text())
    except (OSError, ValueError, TypeError):
        return False


def cmd_import(args) -> int:
    """``dpdfit import``: build a campaign folder from ARTIQ results files as a mapping
    says; prints what was imported."""
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
                    "mapping says (the .toml files in examples/import; the documentation's "
                    "guide page on importing lab recordings).  Every row keeps its source file and rid; "
                    "campaign.json lists the files with their SHA-256.")
    c.add_argument("mapping", metavar="MAP.toml", help="the mapping file")
    c.add_argument("-o", "--output", required=True, metavar="CAMPAIGN_DIR",
                   help="new campaign folder (must not exist, or be empty)")
    c.add_argument("--complete-only", action="store_true",
                   help="skip ndscan scans that did not complete (default: import them "
                        "with a warning)")
    c.set_defaults(func=cmd_import)
    return c
