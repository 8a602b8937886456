"""The types of a mapping's values: what :func:`~.mapping.read_mapping` checks.

A value of the wrong type is refused when the mapping is read, naming its key and
line, and never converted: ``complete_only = "yes"``, ``synthetic = "no"``,
``A = "0.5"``, ``count = true`` or ``format = 5`` would otherwise pass as something
the lab did not write (``bool("no")`` is true).  Integers must be within int64,
the range TOML promises (:data:`~dpdfit.core.defaults.INTEGER_MAX`).
"""

from __future__ import annotations

import datetime
import math

from dpdfit.core.defaults import INTEGER_MAX, ErrorModel
from dpdfit.errors import InputError

from .ramsey import SEQUENCES
from .spam import BASIS_STATES
from .thermometry import SIDEBANDS
from .units import COLUMN_KINDS
from .value_formats import FormatError, check_format

__all__ = ["is_number", "shown", "check_campaign_types", "check_constant",
           "column_modifiers", "TEXT_COLUMNS"]

#: the columns that hold text (labels), the only ones ``format`` and ``labels`` may make
TEXT_COLUMNS = tuple(c for c, (kind, _) in COLUMN_KINDS.items() if kind == "label")
_TIME = "a time (ISO 8601 text or a TOML date-time)"
#: the type each campaign.json key must have in a mapping (the others: ``notes``)
_CAMPAIGN_TYPES = {
    "a number": ("nu_hz", "xi0_spectra_hz", "nbar_assumed", "eta_ref", "eta_ld", "order",
                 "f_det_hz", "fs_traces_hz", "nominal_shots", "parity_phases"),
    "true or false": ("synthetic",),
    "a table": ("predistortion_table", "error_model", "units"),
    "a string": ("name", "phase_run_for_model", "gate_waveform", "generator"),
    _TIME: ("spectra_recorded", "gates_recorded"),
    "text or a list of texts": ("notes",),
}
_IS = {"a number": lambda x: is_number(x), "true or false": lambda x: isinstance(x, bool),
       "a table": lambda x: isinstance(x, dict), "a string": lambda x: isinstance(x, str),
       _TIME: lambda x: isinstance(x, (str, datetime.date, datetime.time)),
       "text or a list of texts": lambda x: isinstance(x, str) or (
           isinstance(x, list) and all(isinstance(n, str) for n in x))}


def is_number(v) -> bool:
    """A TOML number: a float, or an integer within int64 (not ``true``/``false``)."""
    return type(v) is float or (type(v) is int and abs(v) <= INTEGER_MAX)


def shown(v) -> str:
    """A mapping's value as TOML writes it, for messages (strings quoted)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, (dict, list)):
        return "a table" if isinstance(v, dict) else "an array"
    if type(v) is int and abs(v) > INTEGER_MAX:
        return "an integer beyond int64"
    return str(v)


def check_campaign_types(campaign: dict, err) -> None:
    """Refuse a ``[campaign]`` key (known) whose value has the wrong type; ``err`` is
    the mapping's :class:`~.mapping_lines.MappingErrors`."""
    for k, v in campaign.items():
        want = next((t for t, keys in _CAMPAIGN_TYPES.items() if k in keys), None)
        if want is not None and not _IS[want](v):
            err.bad(f"campaign.{k}", f"must be {want}, got {shown(v)}", "campaign", k)
    try:           # the error model's own check, which the diagnosis applies to it later
        ErrorModel.from_dict(campaign.get("error_model", {}))
    except InputError as exc:
        err.bad("campaign.error_model", str(exc), "campaign", "error_model")


def check_constant(column: str, v, key: str, err, table: str) -> None:
    """Refuse a constant of ``column`` that is not a number (text or a time too for a
    text column: run, timestamp, sideband)."""
    text = column in TEXT_COLUMNS
    if not (is_number(v) or text and isinstance(v, (str, datetime.date, datetime.time))):
        err.bad(key, f"a constant of {column} must be {'text or ' if text else ''}a number, "
                f"got {shown(v)}", table, column)
    if column == "prepared":
        _check_states([v], key, err, table)
    if column == "sequence":
        _check_sequences([v], key, err, table)
    if column == "wait_us" and table != "thermometry" and is_number(v) and not v >= 0:
        err.bad(key, f"a wait below zero ({shown(v)} us) is no wait", table, column)
    if table == "pulse_response" and is_number(v):
        _check_pulse_constant(column, v, key, err)
    if column == "attenuation_db" and is_number(v) and not v > 0:
        err.bad(key, f"an attenuation of {shown(v)} dB does not exist: a calibrated "
                "attenuator attenuates (> 0 dB)", table, column)
    if table == "thermometry":
        _check_thermometry_constant(column, v, key, err)


def _check_pulse_constant(column: str, v, key: str, err) -> None:
    """Refuse a constant no AOM pulse response holds: its time axis (every sample of a
    trace at one time: ``pulse_response.csv``'s times must increase within a step), a step
    to an amplitude outside (0, 1] (a step to 0 drives nothing), a negative reading, an
    error that is not positive."""
    why = {"t_us": "a trace's time axis cannot be a constant (every sample at one time): "
                   "map it from the trace's scan axis",
           "A": f"a step to A = {v} is outside (0, 1]" if not 0 < v <= 1 else None,
           "power": f"a reading of {v} is negative" if v < 0 else None,
           "power_err": f"an error of {v} is not > 0" if v <= 0 else None}.get(column)
    if why:
        err.bad(key, why, "pulse_response", column)


def _check_sequences(values, key: str, err, table: str) -> None:
    """Refuse a ``sequence`` value that is no Ramsey sequence (``ramsey`` or ``echo``, as
    ``ramsey.csv`` records it): the import would make rows of a sequence that does not
    exist."""
    for v in values:
        if not (isinstance(v, str) and v.strip().lower() in SEQUENCES):
            err.bad(key, f"sequence {shown(v)} does not exist: the sequences are "
                    f"{', '.join(SEQUENCES)} (text)", table, "sequence")


def _check_thermometry_constant(column: str, v, key: str, err) -> None:
    """Refuse a constant of ``thermometry`` that no recording can hold: a sideband other
    than ``red`` or ``blue``, a negative wait."""
    if column == "sideband":
        _check_sidebands([v], key, err)
    if column == "wait_us" and is_number(v) and v < 0:
        err.bad(key, f"a wait of {shown(v)} us is negative: the probe follows the cooling",
                "thermometry", column)


def _check_sidebands(values, key: str, err) -> None:
    """Refuse a thermometry ``sideband`` that does not exist (``red`` or ``blue``)."""
    for v in values:
        if not (isinstance(v, str) and v.strip().lower() in SIDEBANDS):
            err.bad(key, f"sideband {shown(v)} does not exist: the sidebands are "
                    f"{', '.join(SIDEBANDS)}", "thermometry", "sideband")


def _check_states(values, key: str, err, table: str) -> None:
    """Refuse a ``prepared`` value that is no basis state (text ``00`` .. ``11``, as
    ``spam.csv`` records it; ``|00>`` is read as ``00``): the import would make rows
    of a state that does not exist."""
    states = ", ".join(f'"{s}"' for s in BASIS_STATES)
    for v in values:
        if not isinstance(v, str):
            err.bad(key, f"a prepared state is text, one of {states} (a number loses the "
                    f"leading zero), got {shown(v)}", table, "prepared")
        if v.strip().strip("|>") not in BASIS_STATES:
            err.bad(key, f"prepared state {shown(v)} does not exist: the basis states are "
                    f"{states}", table, "prepared")


def column_modifiers(column: str, v: dict, key: str, err, table: str) -> dict:
    """The checked modifiers of a column (``unit``, ``count``, ...), as the fields of
    its :class:`~.mapping.ColumnSpec`; a bad one is refused naming ``key.modifier``."""
    unit = v.get("unit")
    if unit is not None and not isinstance(unit, str):
        err.bad(f"{key}.unit", "must be a string", table, column)
    count = v.get("count")
    outcomes = count if isinstance(count, list) else [count]
    if count is not None and count != "all" and not (
            outcomes and all(type(c) is int and is_number(c) for c in outcomes)):
        err.bad(f"{key}.count", "must be an integer outcome, a list of them, or \"all\"; got "
                f"{shown(count)}", table, column)
    labels = v.get("labels")
    if labels is not None and not (isinstance(labels, dict)
                                   and all(isinstance(x, str) for x in labels.values())):
        err.bad(f"{key}.labels", "must be a table { code = \"name\" } (each name a string)",
                table, column)
    if labels is not None and column == "prepared":
        _check_states(labels.values(), f"{key}.labels", err, table)
    if labels is not None and column == "sequence":
        _check_sequences(labels.values(), f"{key}.labels", err, table)
    if isinstance(labels, dict) and column == "sideband" and table == "thermometry":
        _check_sidebands(labels.values(), f"{key}.labels", err)
    fs = v.get("full_scale_dbm")
    if fs is not None and not (is_number(fs) and math.isfinite(fs)):
        err.bad(f"{key}.full_scale_dbm", f"must be a finite number (dBm), got {shown(fs)}",
                table, column)
    fmt = v.get("format")
    if fmt is not None:
        try:
            check_format(fmt)
        except FormatError as exc:
            err.bad(f"{key}.format", str(exc), table, column)
    for modifier in ("format", "labels"):
        if v.get(modifier) is not None and column not in TEXT_COLUMNS:
            err.bad(f"{key}.{modifier}", f"makes text, and {column} holds numbers (the text "
                    f"columns are {', '.join(TEXT_COLUMNS)})", table, column)
    return dict(unit=unit, full_scale_dbm=None if fs is None else float(fs), format=fmt,
                labels=labels, count=count)
