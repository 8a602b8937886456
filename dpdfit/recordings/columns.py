"""The columns of each campaign table, required and optional, as its reader reads them.

Stated once: the readers (:func:`~dpdfit.recordings.tables.read_calibration_table`,
:attr:`~dpdfit.recordings.campaign_folder.CampaignFolder.spectra` and
``time_scans``, :func:`~dpdfit.recordings.counts.read_populations`,
:func:`~dpdfit.recordings.counts.read_parity`,
:func:`~dpdfit.recordings.gate_rates.read_gate_rates`) read these, and the import
mapping derives its columns from them (:data:`dpdfit.recordings.mapping.TABLE_COLUMNS`).
Each entry is ``(required, optional)``; ``populations.csv`` needs ``n_even`` or the
three counts ``n00, n01_10, n11`` besides its required columns.
"""

from __future__ import annotations

import os

import pandas as pd

__all__ = ["CAMPAIGN_TABLES", "LABELS_ONLY", "missing_optional_columns", "missing_column_lines"]

#: campaign table (its file without ``.csv``) -> (required columns, optional columns)
CAMPAIGN_TABLES = {
    "calibration_amplitude": (("A", "power"), ("power_err", "run", "timestamp")),
    "calibration_phase": (("A", "phase_rad"), ("phase_err", "run", "timestamp")),
    "spectra": (("A", "dpd", "sideband", "n", "P_dB"), ("valid", "snr_db", "repeat")),
    "populations": (("A", "dpd", "scan", "shots"), ("n_even", "n00", "n01_10", "n11")),
    "parity": (("A", "dpd", "scan", "phase_rad", "n_even", "shots"), ()),
    "time_scans": (("A", "dpd", "t_us", "n00", "n11", "shots"), ("n01_10",)),
    "gate_rates": (("A", "dpd", "xi0_khz"), ("xi0_err_khz",)),
}

#: optional columns whose absence leaves nothing out (a label the reader can infer):
#: never listed as missing
LABELS_ONLY = ("repeat",)


def missing_optional_columns(path: str | os.PathLike, table: str) -> list[str]:
    """The optional columns of ``table`` that the header of its file ``path`` lacks
    (for ``populations`` the three counts ``n00, n01_10, n11``: ``n_even`` follows from
    them; never the :data:`LABELS_ONLY`).  Only the header is read; a file whose header
    cannot be read lacks nothing here (its reader says what is wrong)."""
    try:
        have = {str(c).strip() for c in pd.read_csv(path, comment="#", nrows=0).columns}
    except (OSError, ValueError, UnicodeDecodeError):
        return []
    wanted = ("n00", "n01_10", "n11") if table == "populations" else CAMPAIGN_TABLES[table][1]
    return [c for c in wanted if c not in have and c not in LABELS_ONLY]


def missing_column_lines(path: str | os.PathLike, table: str,
                         consequences: dict | None = None) -> list[str]:
    """What the file ``path`` of ``table`` lacks of its optional columns, one line each.

    ``consequences`` maps ``(table, columns)`` to what an analysis does without those
    columns; a missing group's line says that instead of the generic one (one line per
    absence, never two)."""
    missing = missing_optional_columns(path, table)
    out = []
    for (t, group), why in (consequences or {}).items():
        if t == table and set(group) & set(missing):
            out.append(f"{table}.csv has no {'/'.join(group)}: {why}")
            missing = [c for c in missing if c not in group]
    if missing:
        out.append(f"{table}.csv has no optional column {', '.join(missing)}")
    return out
