"""What ``dpdfit add`` refuses before it merges: recordings the campaign cannot take.

Each check raises one :class:`~dpdfit.errors.InputError` naming the file, column and
row (or key) of NEW:

* :func:`check_same_campaign` -- NEW's campaign constants (its ``campaign.json``, or the
  mapping's ``[campaign]``) differ from CAMPAIGN's in one of :data:`SETUP_KEYS`: the
  gate detuning, the predistortion table or the ion setup (numbers compared with the
  relative tolerance :data:`RTOL`, text exactly; a key absent on either side is not
  compared);
* :func:`check_settings` -- a setting the campaign cannot model: ``A`` outside [0, 1]
  or ``dpd`` not 0 or 1;
* :func:`check_output` -- the output folder exists (even empty: ``dpdfit add`` writes
  a new campaign folder), lies inside CAMPAIGN (or is it), or inside NEW's folder of
  CSVs; NEW is CAMPAIGN itself;
* :func:`same_run` -- whether a calibration run of NEW equals the campaign's run of that
  label (the merge skips it) or differs (the merge refuses it).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pandas as pd

from dpdfit.errors import InputError

__all__ = ["SETUP_KEYS", "RTOL", "check_same_campaign", "check_settings", "check_output",
           "same_run"]

#: campaign.json keys that identify the campaign's setup: two sets of recordings that
#: differ in one were not taken on the same campaign
SETUP_KEYS = ("nu_hz", "xi0_spectra_hz", "f_det_hz", "eta_ld", "eta_ref", "parity_phases",
              "predistortion_table.amplitude_run", "predistortion_table.points",
              "predistortion_table.order", "predistortion_table.interpolation")
#: relative tolerance of numbers compared (written as text with 10 significant digits
#: or more, a number read back differs by less)
RTOL = 1e-9


def _value(meta: dict, key: str):
    """The value of a dotted key, or a marker that it is absent."""
    for part in key.split("."):
        if not isinstance(meta, dict) or part not in meta:
            return _ABSENT
        meta = meta[part]
    return _ABSENT if meta is None else meta


_ABSENT = object()


def _number(v):
    if isinstance(v, bool):
        return None
    try:
        x = float(v)
    except (TypeError, ValueError, OverflowError):
        return None
    return x if math.isfinite(x) else None


def _same(a, b) -> bool:
    x, y = _number(a), _number(b)
    if x is not None and y is not None:
        return math.isclose(x, y, rel_tol=RTOL, abs_tol=0.0)
    return str(a).strip() == str(b).strip()


def check_same_campaign(campaign_meta: dict, campaign_file: str, new) -> None:
    """Refuse NEW (a :class:`~.add_sources.NewRecordings`) whose constants differ from the
    campaign's in a :data:`SETUP_KEYS` key (module doc)."""
    for key in SETUP_KEYS:
        mine, theirs = _value(campaign_meta, key), _value(new.constants, key)
        if mine is _ABSENT or theirs is _ABSENT or _same(mine, theirs):
            continue
        raise InputError(f"{new.constants_line(key)} is {theirs!r}, but {mine!r} in "
                         f"{campaign_file}: recordings of another campaign (another "
                         f"{_WHAT.get(key.split('.')[0], 'setup')}) are not added",
                         file=new.constants_file)


_WHAT = {"nu_hz": "gate detuning", "xi0_spectra_hz": "spectra detuning",
         "f_det_hz": "heterodyne detection frequency", "eta_ld": "ion setup",
         "eta_ref": "AOM reference efficiency", "parity_phases": "parity design",
         "predistortion_table": "predistortion table"}


def check_settings(new) -> None:
    """Refuse a row of NEW at a setting the campaign cannot model: ``A`` outside [0, 1],
    ``dpd`` other than 0 or 1 (or not a number), naming NEW's file, column and row."""
    for table, df in new.tables.items():
        for col in ("A", "dpd"):
            if col not in df.columns:
                continue
            text = df[col]
            x = pd.to_numeric(text, errors="coerce").to_numpy(dtype=float)
            ok = np.isfinite(x) & (x >= 0) & (x <= 1)
            if col == "dpd":
                ok &= (x == 0) | (x == 1)
            if ok.all():
                continue
            i = int(np.flatnonzero(~ok)[0])
            why = ("must be 0 or 1 (an unknown dpd flag)" if col == "dpd"
                   else "is outside [0, 1] (the normalised RF amplitude)")
            raise InputError(f"{col} = {text.iloc[i]!r} {why}: the campaign cannot model "
                             "this setting", column=col, **new.where(table, i + 1))


def check_output(out, campaign: Path, new: Path, new_is_folder: bool) -> None:
    """Refuse an output folder that exists, is CAMPAIGN or inside it, or inside NEW's
    folder of CSVs; refuse NEW that is CAMPAIGN (module doc)."""
    out_path = Path(out)
    if out_path.exists() or out_path.is_symlink():
        raise InputError("exists: dpdfit add writes a new campaign folder and never "
                         "writes into an existing one; choose a new name", file=str(out))
    # realpath, not Path.resolve: a link loop is the readers' to refuse, not a crash here
    o, c, n = (Path(os.path.realpath(p)) for p in (out_path, campaign, new))
    if o == c or c in o.parents:
        raise InputError(f"lies inside the campaign folder {campaign}, which dpdfit add "
                         "never writes into; choose a folder outside it", file=str(out))
    if new_is_folder and (o == n or n in o.parents):
        raise InputError(f"lies inside NEW ({new}), a folder of recordings dpdfit add reads; "
                         "choose a folder outside it", file=str(out))
    if new_is_folder and n == c:
        raise InputError("NEW is the campaign folder itself: its recordings are in it "
                         "already", file=str(new))


def same_run(mine: pd.DataFrame, theirs: pd.DataFrame) -> str | None:
    """None when two runs of one label hold the same rows (numbers within :data:`RTOL`,
    timestamps as instants); else what differs first (``"row 3, column 'power'"``)."""
    if len(mine) != len(theirs):
        return f"{len(theirs)} rows against the campaign's {len(mine)}"
    cols = [c for c in mine.columns if c in theirs.columns and c not in
            ("run", "source_file", "source_rid")]
    for c in cols:
        a, b = mine[c].to_numpy(dtype=object), theirs[c].to_numpy(dtype=object)
        for i, (x, y) in enumerate(zip(a, b)):
            if not _same_cell(c, x, y):
                return f"row {i + 1} of the run, column '{c}': {y!r} against {x!r}"
    return None


def _same_cell(column: str, x: str, y: str) -> bool:
    if column == "timestamp":
        tx = pd.to_datetime(x, utc=True, errors="coerce")
        ty = pd.to_datetime(y, utc=True, errors="coerce")
        return (tx == ty) if not (pd.isna(tx) or pd.isna(ty)) else x == y
    return _same(x, y) if x != "" and y != "" else x == y
