"""The files of a campaign folder that ``dpdfit add`` copies into the new folder.

``dpdfit add`` copies only the files of the campaign folder's layout
(``docs/getting-started.md``, "The campaign folder"), :data:`LAYOUT_FILES`: the
tables it adds no rows to, ``traces.csv`` and the trace files it names, ``budget.toml``
and ``README.md``.  ``campaign.json`` and the tables with rows added are written anew,
``truth.json`` is dropped (:data:`DROPPED_FILES`).  Every other file or folder of
CAMPAIGN -- a lab's notes, an old analysis, a trace that ``traces.csv`` does not
name -- is left out, each named in the report: nothing of it is read, and a link
among them is never followed.

A file copied is checked before a byte of it is (:mod:`.input_files`): a regular file,
inside CAMPAIGN (a symbolic link to another file of CAMPAIGN is copied as that file;
one leading out of CAMPAIGN is refused, as is a FIFO, a device or a folder in its
place), at most :func:`~.input_files.max_input_bytes`; a table is parsed as its reader
parses it (:mod:`.csv_text`: a cell a spreadsheet would run, a NUL byte, a row wider than
its header are refused, not copied); it is then written fresh into the new folder, a
regular file, never a link.  Each refusal is one
:class:`~dpdfit.errors.InputError` naming the file.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from dpdfit.errors import InputError, RefusedFileError

from .columns import CAMPAIGN_TABLES
from .input_files import check_inside, copy_input_file, open_input
from .tables import read_csv_strings

__all__ = ["LAYOUT_FILES", "DROPPED_FILES", "TRACES_FOLDER", "CampaignCopy", "plan_copy",
           "check_file"]

#: files of the campaign layout copied as they are (unless rows are added to a table)
LAYOUT_FILES = (*(f"{t}.csv" for t in CAMPAIGN_TABLES), "traces.csv", "budget.toml",
                "README.md")
#: files of CAMPAIGN not copied: name -> why
DROPPED_FILES = {"truth.json": "a simulator's truth, which no longer describes the folder "
                               "with the recordings added"}
#: the layout's folder of raw traces (made in the new folder when CAMPAIGN has it)
TRACES_FOLDER = "traces"
#: at most this many lines name the files left out of one folder; then a count
_MAX_LINES = 10


@dataclass(frozen=True)
class CampaignCopy:
    """What ``dpdfit add`` copies of CAMPAIGN: ``files`` (paths relative to CAMPAIGN,
    ``/``-separated), ``folders`` to make (empty ones included) and the lines of the
    report naming what is ``left_out``."""

    files: tuple = ()
    folders: tuple = ()
    left_out: tuple = ()

    def copy(self, campaign: Path, dest: Path, skip=()) -> None:
        """Copy the files (but those in ``skip``, written anew) into the folder ``dest``
        (module doc: checked again as they are copied, each written fresh; a table parsed
        first, as :func:`~.tables.read_csv_strings` parses it)."""
        for d in self.folders:
            (dest / d).mkdir(parents=True, exist_ok=True)
        for rel in self.files:
            if rel in skip:
                continue
            target = dest / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            if rel in LAYOUT_FILES and rel.endswith(".csv"):
                _check_table(campaign / rel, campaign)
            copy_input_file(campaign / rel, target, within=campaign, what=_what(rel))


def _check_table(path: Path, campaign: Path) -> None:
    """Refuse a table of CAMPAIGN that is no table a lab writes (a cell a spreadsheet
    would run, a NUL byte, a row wider than its header: :mod:`.csv_text`), parsed as its
    reader parses it, rather than copy it blind.  A table its reader refuses for other
    reasons (empty, as the simulator's ``traces.csv`` without traces) is copied as it
    is, as every file was before: the reader says so when the new folder is analysed."""
    try:
        read_csv_strings(path, within=campaign)
    except RefusedFileError:
        raise
    except InputError:
        return


def _what(rel: str) -> str:
    return "trace" if rel not in LAYOUT_FILES else (
        "table" if rel.endswith(".csv") else "file of the campaign")


def check_file(path: Path, within: Path, what: str, limit: int | None = None) -> Path:
    """``path`` checked as :func:`~.input_files.open_input` checks it (a regular file
    inside ``within``, at most ``limit`` bytes), without reading it."""
    with open_input(path, within=within, what=what, limit=limit):
        pass
    return path


def plan_copy(campaign: Path, written, traces) -> CampaignCopy:
    """The files of ``campaign`` to copy (module doc), every one checked now, before
    anything is written; ``written``: the names written anew (``campaign.json``, the
    tables with rows added); ``traces``: the ``file`` column of ``traces.csv`` (a list of
    text), or a line saying why it cannot be read (a string)."""
    files, folders = [], []
    named, left_out = _named_traces(campaign, traces)
    for entry in sorted(os.scandir(campaign), key=lambda e: e.name):
        name = entry.name
        if name in written or name in DROPPED_FILES:
            continue
        if name in LAYOUT_FILES or name in named:
            check_file(campaign / name, campaign, _what(name))
            files.append(name)
        elif name == TRACES_FOLDER and entry.is_dir(follow_symlinks=False):
            folders.append(name)
            left_out += _unnamed(campaign, name, named, traces)
        else:
            kind = "/" if entry.is_dir(follow_symlinks=False) else ""
            left_out.append(f"{name}{kind} (not a file of the campaign layout; copy it by "
                            "hand if it belongs in the new folder)")
    for rel in sorted(named):
        if "/" in rel:
            check_file(campaign / rel, campaign, "trace")
            files.append(rel)
    return CampaignCopy(files=tuple(files), folders=tuple(folders), left_out=tuple(left_out))


def _named_traces(campaign: Path, traces) -> tuple[set, list]:
    """The trace files ``traces.csv`` names, relative to CAMPAIGN, and the lines of those
    not copied: a name leading out of CAMPAIGN is refused; one that does not exist, or
    is not a path relative to the folder, is not copied (the new folder's
    ``traces.csv`` names it as CAMPAIGN's does); the layout's own files are no traces."""
    if isinstance(traces, str):
        return set(), []
    out, lines = set(), []
    top = os.path.normpath(campaign)
    for value in dict.fromkeys(str(v).strip() for v in traces):
        if not value:
            continue
        path = campaign / value
        check_inside(path, campaign, "trace")
        rel = os.path.relpath(os.path.normpath(path), top)
        if os.path.isabs(value) or rel.startswith(".."):
            lines.append(f"{value} (named by traces.csv, not by a path relative to the "
                         "campaign folder)")
            continue
        rel = Path(rel).as_posix()
        if rel == "." or rel in LAYOUT_FILES or rel in DROPPED_FILES or rel == "campaign.json":
            continue
        if not os.path.exists(path):
            lines.append(f"{rel} (named by traces.csv, but not in the campaign folder)")
            continue
        out.add(rel)
    return out, lines


def _unnamed(campaign: Path, folder: str, named: set, traces) -> list[str]:
    """Lines naming the files of ``folder`` that ``traces.csv`` does not name (links not
    followed)."""
    why = ("not named by traces.csv" if not isinstance(traces, str)
           else f"traces.csv names no trace: {traces}")
    found = []
    for root, dirs, names in os.walk(campaign / folder):
        dirs.sort()
        for n in sorted(names) + [d for d in dirs if os.path.islink(os.path.join(root, d))]:
            rel = Path(root, n).relative_to(campaign).as_posix()
            if rel not in named:
                found.append(rel)
    lines = [f"{rel} ({why})" for rel in found[:_MAX_LINES]]
    if len(found) > _MAX_LINES:
        lines.append(f"... and {len(found) - _MAX_LINES} more files of {folder}/ ({why})")
    return lines
