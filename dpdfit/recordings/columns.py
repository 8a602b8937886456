"""The columns of each campaign table, required and optional, as its reader reads them.

Stated once: the readers (:func:`~dpdfit.recordings.tables.read_calibration_table`,
:attr:`~dpdfit.recordings.campaign_folder.CampaignFolder.spectra` and
``time_scans``, :func:`~dpdfit.recordings.counts.read_populations`,
:func:`~dpdfit.recordings.counts.read_parity`,
:func:`~dpdfit.recordings.gate_rates.read_gate_rates`,
:func:`~dpdfit.recordings.spam.read_spam`,
:func:`~dpdfit.recordings.pulse_response.read_pulse_response`,
:func:`~dpdfit.recordings.ramsey.read_ramsey`,
:func:`~dpdfit.recordings.detector_linearity.read_detector_linearity`,
:func:`~dpdfit.recordings.thermometry.read_thermometry`) read these, and the import
mapping derives its columns from them (:data:`dpdfit.recordings.mapping.TABLE_COLUMNS`).
Each entry is ``(required, optional)``; ``populations.csv`` needs ``n_even`` or the
three counts ``n00, n01_10, n11`` besides its required columns.
"""

from __future__ import annotations

import os

from dpdfit.errors import InputError

from .csv_text import header_line, header_names
from .input_files import open_input

__all__ = ["CAMPAIGN_TABLES", "LABELS_ONLY", "header_columns", "missing_optional_columns",
           "missing_column_lines", "MISSING_LINES"]

#: campaign table (its file without ``.csv``) -> (required columns, optional columns)
CAMPAIGN_TABLES = {
    "calibration_amplitude": (("A", "power"), ("power_err", "run", "timestamp")),
    "calibration_phase": (("A", "phase_rad"), ("phase_err", "run", "timestamp")),
    "spectra": (("A", "dpd", "sideband", "n", "P_dB"), ("valid", "snr_db", "repeat")),
    "populations": (("A", "dpd", "scan", "shots"), ("n_even", "n00", "n01_10", "n11")),
    "parity": (("A", "dpd", "scan", "phase_rad", "n_even", "shots"), ()),
    "time_scans": (("A", "dpd", "t_us", "n00", "n11", "shots"), ("n01_10",)),
    "gate_rates": (("A", "dpd", "xi0_khz"), ("xi0_err_khz",)),
    "spam": (("prepared", "n00", "n01_10", "n11", "shots"), ("run", "timestamp")),
    "pulse_response": (("t_us", "power"), ("A", "power_err", "run", "timestamp")),
    "ramsey": (("sequence", "wait_us", "n00", "n01_10", "n11", "shots"), ("run", "timestamp")),
    "detector_linearity": (("A", "power", "power_attenuated", "attenuation_db"),
                           ("power_err", "run", "timestamp")),
    "thermometry": (("wait_us", "sideband", "n_bright", "shots"), ("run", "timestamp")),
}

#: optional columns whose absence leaves nothing out (a label the reader can infer):
#: never listed as missing
LABELS_ONLY = ("repeat",)
#: tables none of whose optional columns any analysis reads (labels of the lab's own):
#: their absence is never listed either
_LABELLED_ONLY = ("spam", "pulse_response", "ramsey", "detector_linearity", "thermometry")
#: what a table without one of its required columns lacks, where the column's name alone
#: does not say it (the reader's and ``dpdfit add``'s line)
MISSING_LINES = {("pulse_response", "t_us"): "pulse_response.csv has no time axis (column t_us)"}


def header_columns(path: str | os.PathLike, *, within=None) -> list[str]:
    """The column names of the CSV file ``path`` as its reader names them
    (:func:`~dpdfit.recordings.csv_text.header_names`), reading the file only up to its
    header's line, through :func:`~dpdfit.recordings.input_files.open_input` (inside
    ``within`` when given); an InputError naming the file when it cannot be read or has
    no header."""
    name = str(path)
    data = b""
    with open_input(path, within=within, what="file") as fh:
        while True:
            chunk = fh.read(max(1 << 16, len(data)))     # doubling: linear in the size
            data += chunk
            found = header_line(data, name, whole=not chunk)
            if found is not None or not chunk:
                break
    if found is None:
        raise InputError("file is empty (no header, no data)", file=name)
    return header_names(found[1], name)


def missing_optional_columns(path: str | os.PathLike, table: str, *,
                             within=None) -> list[str]:
    """The optional columns of ``table`` that the header of its file ``path`` lacks
    (for ``populations`` the three counts ``n00, n01_10, n11``: ``n_even`` follows from
    them; never the :data:`LABELS_ONLY`, nor the labels of ``spam``).  Only the header is read (inside ``within``
    when given); a file whose header cannot be read lacks nothing here (its reader says
    what is wrong)."""
    try:
        have = set(header_columns(path, within=within))
    except InputError:
        return []
    if table in _LABELLED_ONLY:
        return []
    wanted = ("n00", "n01_10", "n11") if table == "populations" else CAMPAIGN_TABLES[table][1]
    return [c for c in wanted if c not in have and c not in LABELS_ONLY]


def missing_column_lines(path: str | os.PathLike, table: str,
                         consequences: dict | None = None, *, within=None) -> list[str]:
    """What the file ``path`` of ``table`` lacks of its optional columns, one line each.

    ``consequences`` maps ``(table, columns)`` to what an analysis does without those
    columns; a missing group's line says that instead of the generic one (one line per
    absence, never two)."""
    missing = missing_optional_columns(path, table, within=within)
    out = []
    for (t, group), why in (consequences or {}).items():
        if t == table and set(group) & set(missing):
            out.append(f"{table}.csv has no {'/'.join(group)}: {why}")
            missing = [c for c in missing if c not in group]
    if missing:
        out.append(f"{table}.csv has no optional column {', '.join(missing)}")
    return out
