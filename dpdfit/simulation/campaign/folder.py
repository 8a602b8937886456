"""Writing a campaign folder: its files, CSV text, the atomic move into place, file hashes."""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import pandas as pd

from dpdfit.errors import InputError
from dpdfit.recordings.outputs import staged_folder

__all__ = ["CAMPAIGN_FILES", "csv_text", "check_new_folder", "write_folder", "campaign_hashes"]

CAMPAIGN_FILES = ("campaign.json", "calibration_amplitude.csv", "calibration_phase.csv",
                  "spectra.csv", "traces.csv", "populations.csv", "parity.csv",
                  "gate_rates.csv", "time_scans.csv", "README.md", "truth.json")


def csv_text(df: pd.DataFrame) -> str:
    """A table as the campaign's CSV text (10 significant digits, ``\\n`` line ends)."""
    return df.to_csv(index=False, float_format="%.10g", lineterminator="\n")


def check_new_folder(out: Path) -> None:
    """InputError unless ``out`` does not exist or is an empty folder."""
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise InputError("output folder exists and is not empty; choose a new folder",
                         file=str(out))


def write_folder(out: Path, files: dict, bundled: dict) -> None:
    """Write ``files`` (name -> text) and ``bundled`` (name -> bytes, under ``traces/``).

    Files are written into a temporary folder beside ``out`` and moved into
    place only when complete.
    """
    with staged_folder(out) as tmp:
        (tmp / "traces").mkdir()
        for name, text in files.items():
            (tmp / name).write_text(text)
        for name, data in bundled.items():
            (tmp / name).write_bytes(data)


def campaign_hashes(folder: str | os.PathLike) -> dict:
    """SHA-256 of every file of a campaign folder (relative path -> hex)."""
    folder = Path(folder)
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}
