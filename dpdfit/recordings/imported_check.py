"""An imported campaign read back before it appears, its refusals named by their source.

:func:`check_imported` reads a staged campaign folder (the tables and ``campaign.json``
that :meth:`~.campaign_import.ImportedCampaign.write` wrote to a temporary folder) with
the campaign folder's own readers.  A refusal must not name the staged file, a
temporary path gone by the time the user reads it: a row of a table is named by the
results file and rid it came from, a recording time of ``campaign.json`` by the
mapping key that gave it or, when it defaulted, by the results file whose start time
it is.
"""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd

from dpdfit.errors import InputError

from .campaign_folder import CampaignFolder

__all__ = ["check_imported", "READERS"]

#: the CampaignFolder property that reads each imported table
READERS = {"calibration_amplitude": "amplitude_runs", "calibration_phase": "phase_runs",
           "spectra": "spectra", "populations": "populations", "parity": "parity",
           "time_scans": "time_scans", "gate_rates": "gate_rates", "spam": "spam",
           "pulse_response": "pulse_response", "ramsey": "ramsey",
           "detector_linearity": "detector_linearity",
           "thermometry": "thermometry"}
#: the tables whose files' earliest start time each recording time defaults to
_RECORDED_FROM = {"spectra_recorded": ("spectra",),
                  "gates_recorded": ("populations", "parity", "time_scans", "gate_rates")}


def check_imported(folder: Path, tables: dict, meta: dict, mapping=None) -> None:
    """Read the staged campaign ``folder`` as :class:`CampaignFolder` does; raise the
    first refusal as an :class:`InputError` naming where its value came from (module
    doc).  ``tables`` and ``meta`` are what was written, ``mapping`` the
    :class:`~.mapping.Mapping` it was imported by (None: unknown)."""
    try:
        camp = CampaignFolder(folder)
    except InputError as exc:
        raise _meta_traced(exc, meta, mapping) from None
    for name in tables:
        try:
            getattr(camp, READERS[name])
        except InputError as exc:
            raise _traced(exc, name, tables[name]) from None
    try:
        camp.recording_times
    except InputError as exc:
        raise _meta_traced(exc, meta, mapping) from None


def _message(exc: InputError) -> str:
    """The message without its file (the staged one) and its line there."""
    return re.sub(r" \(line \d+\)$", "", str(exc).split(": ", 1)[-1])


def _traced(exc: InputError, table: str, df: pd.DataFrame) -> InputError:
    # the row's line in the staged CSV means nothing to the user: the results file does
    msg = _message(exc)
    if exc.row is not None and 1 <= exc.row <= len(df):
        r = df.iloc[exc.row - 1]
        return InputError(f"imported {table} (row {exc.row}, column '{exc.column}'): {msg}",
                          file=f"{r['source_file']} (rid {r['source_rid']})")
    return InputError(f"imported {table}: {msg}")


def _meta_traced(exc: InputError, meta: dict, mapping) -> InputError:
    msg = _message(exc)
    key = next((k for k in _RECORDED_FROM if f"'{k}'" in msg), None)
    if key is not None and mapping is not None and key in mapping.campaign:
        return InputError(f"[campaign] {msg}", file=str(mapping.path))
    tables = _RECORDED_FROM.get(key, ())
    sources = [s for s in meta.get("imported", {}).get("sources", ())
               if s.get("start_time") and set(s.get("tables", ())) & set(tables)]
    if mapping is None or not sources:
        return InputError(f"imported campaign.json: {msg}")
    first = min(sources, key=lambda s: pd.Timestamp(s["start_time"]))
    return InputError(f"its start_time is campaign.json's {key} (the earliest of the "
                      f"{'/'.join(tables)} files): {msg}",
                      file=f"{first['file']} (rid {first['rid']})")
