"""``detector_linearity.csv``: the calibration photodiode read with and without a calibrated
attenuator, at several drive settings.

Every calibration run reads the AOM through the same photodiode, so a nonlinear
photodiode and an AOM that moved (a stale predistortion table) bend the same curve.  An
attenuator of known attenuation separates them: a linear detector reads the ratio
``10^(-attenuation_db/10)`` of the two readings at every power, a nonlinear one a ratio
that changes with the power, whatever the AOM did.

One row per reading pair: ``A`` (the drive amplitude, as the calibration runs record it),
``power`` (the reading without the attenuator, the lab's own unit, as
``calibration_amplitude.csv``), ``power_attenuated`` (with it, same unit),
``attenuation_db`` (the attenuator's calibrated attenuation, dB, > 0); optional
``power_err`` (1-sigma of ``power``, same unit; the attenuated reading is taken with the
same relative error) and ``run``, ``timestamp`` (labels).  :func:`read_detector_linearity`
refuses, each as one :class:`~dpdfit.errors.InputError` line naming the file, the column
and the data row: a reading below zero (``power`` at zero too: it has no ratio), an
attenuation of zero or below, an ``A`` outside the calibration runs' range, and as a unit
slip (:class:`~dpdfit.errors.ImplausibleValueError`) an attenuation no dB value of an
attenuator takes (a linear factor in the dB column) or one the readings contradict.
A drive recorded again is a further row: every pair is a measurement of its own.
"""

from __future__ import annotations

import os

import numpy as np
import pandas as pd

from dpdfit.errors import ImplausibleValueError, InputError

from .columns import CAMPAIGN_TABLES
from .tables import read_table

__all__ = ["read_detector_linearity", "MIN_ATTENUATION_DB", "MAX_ATTENUATION_DB",
           "MAX_RATIO_DISAGREEMENT_DB", "transmission", "LOWEST_DRIVE", "linearity_drives"]

#: The smallest attenuation (dB) taken as an attenuator's: a linearity check needs a
#: ratio the readings resolve against a few-percent nonlinearity (ND filters and fibre
#: attenuators for the purpose are 3-20 dB); 0.1 or 0.5 in the column is a transmission
#: (a linear factor, 0.1 = 10 dB) written where dB belongs.
MIN_ATTENUATION_DB = 1.0
#: The largest attenuation (dB) taken as an attenuator's: beyond it the attenuated
#: reading of a calibration photodiode (signal-to-noise ~ 10^3 at full scale) is noise;
#: 100 or 1000 in the column is an attenuation factor (100 = 20 dB) written as dB.
MAX_ATTENUATION_DB = 60.0
#: The most (dB) the attenuation the readings show (``10 log10(power/power_attenuated)``
#: at the file's highest readings) may differ from the stated one: a detector
#: nonlinearity of the catalog's range (``|k| <= 0.5``) moves it by 1.8 dB at most,
#: a wrong attenuator or a unit slip by far more.
MAX_RATIO_DISAGREEMENT_DB = 3.0


#: the weakest drive of a characterisation the diagnosis proposes: its power, ~5 % of
#: full scale, is where a nonlinear reading error has faded (the ratio's reference),
#: its attenuated reading still ~20x the calibration photodiode's noise floor
LOWEST_DRIVE = 0.2


def linearity_drives(points: int) -> np.ndarray:
    """``points`` drives from :data:`LOWEST_DRIVE` to full drive, evenly spaced: those a
    proposed characterisation reads (the schedule's ``A``) and the simulator records."""
    return np.round(np.linspace(LOWEST_DRIVE, 1.0, int(points)), 10)


def transmission(attenuation_db) -> np.ndarray:
    """The attenuator's power transmission ``10^(-attenuation_db/10)``."""
    return 10.0 ** (-np.asarray(attenuation_db, dtype=float) / 10.0)


def _first(bad: np.ndarray) -> int:
    return int(np.flatnonzero(bad)[0])


def _check_readings(df: pd.DataFrame, file: str) -> None:
    """``power > 0`` (a ratio needs it), ``power_attenuated >= 0``."""
    for col, floor in (("power", True), ("power_attenuated", False)):
        v = df[col].to_numpy(dtype=float)
        bad = (v <= 0) if floor else (v < 0)
        if bad.any():
            i = _first(bad)
            what = "negative" if v[i] < 0 else "zero (no ratio to the attenuated reading)"
            raise InputError(f"reading {v[i]:g} is {what}: the photodiode reading, background "
                             "subtracted, must be above zero here", file=file, column=col,
                             row=i + 1)


def _check_attenuation(df: pd.DataFrame, file: str) -> None:
    """An attenuation above zero, of an attenuator's size in dB, and as the readings
    show it (module doc)."""
    att = df["attenuation_db"].to_numpy(dtype=float)
    bad = att <= 0
    if bad.any():
        i = _first(bad)
        raise InputError(f"attenuation {att[i]:g} dB must be > 0: an attenuator attenuates",
                         file=file, column="attenuation_db", row=i + 1)
    low, high = att < MIN_ATTENUATION_DB, att > MAX_ATTENUATION_DB
    if low.any() or high.any():
        i = _first(low | high)
        hint = (f"a transmission (a linear factor, {att[i]:g} = "
                f"{-10 * np.log10(att[i]):.3g} dB) written in the dB column?" if att[i] < 1
                else f"an attenuation factor ({att[i]:g} = {10 * np.log10(att[i]):.3g} dB) "
                     "written in the dB column?")
        raise ImplausibleValueError(
            f"attenuation {att[i]:g} dB is outside [{MIN_ATTENUATION_DB:g}, "
            f"{MAX_ATTENUATION_DB:g}] dB of a calibrated attenuator: {hint}",
            file=file, column="attenuation_db", row=i + 1)
    p, pa = df["power"].to_numpy(dtype=float), df["power_attenuated"].to_numpy(dtype=float)
    strong = p >= 0.5 * p.max()            # the best-resolved pairs
    with np.errstate(divide="ignore"):
        seen = 10 * np.log10(p / np.maximum(pa, 1e-300))
    off = strong & (np.abs(seen - att) > MAX_RATIO_DISAGREEMENT_DB)
    if off.any():
        i = _first(off)
        raise ImplausibleValueError(
            f"attenuation {att[i]:g} dB but the readings' ratio shows {seen[i]:.3g} dB, more "
            f"than {MAX_RATIO_DISAGREEMENT_DB:g} dB apart: another attenuator, a unit slip, "
            "or the columns swapped?", file=file, column="attenuation_db", row=i + 1)


def _check_drive_range(df: pd.DataFrame, file: str, a_range) -> None:
    """Every ``A`` within the calibration runs' range ``a_range = (lo, hi)``."""
    lo, hi = (float(x) for x in a_range)
    a = df["A"].to_numpy(dtype=float)
    bad = (a < lo - 1e-12) | (a > hi + 1e-12)
    if bad.any():
        i = _first(bad)
        raise InputError(f"A = {a[i]:g} is outside the calibration runs' range [{lo:g}, "
                         f"{hi:g}]: the detector is compared at the calibration's drives",
                         file=file, column="A", row=i + 1)


def read_detector_linearity(path: str | os.PathLike, *, within=None,
                            a_range=None) -> pd.DataFrame:
    """Read and validate a detector-linearity file ``A, power, power_attenuated,
    attenuation_db`` (+ ``power_err``, ``run``, ``timestamp``).

    ``A`` in [0, 1] and, with ``a_range`` (the calibration runs' ``(min A, max A)``),
    within it; the readings and the attenuation as the module doc says.  ``within``: the
    folder the file must lie in (a campaign folder,
    :func:`~dpdfit.recordings.tables.read_csv_strings`).

    Returns
    -------
    pandas.DataFrame
        One row per reading pair, in file order (the index is the 0-based data row):
        the numeric columns as float64, plus ``transmission`` (:func:`transmission`).
    """
    name = str(path)
    required, optional = (list(c) for c in CAMPAIGN_TABLES["detector_linearity"])
    df = read_table(path, required, optional,
                    numeric=["A", "power", "power_attenuated", "attenuation_db", "power_err"],
                    ranges={"A": (0.0, 1.0)}, positive=["power_err"], within=within)
    if df.empty:
        raise InputError("has a header but no data rows", file=name)
    _check_readings(df, name)
    _check_attenuation(df, name)
    if a_range is not None:
        _check_drive_range(df, name, a_range)
    df["transmission"] = transmission(df["attenuation_db"])
    df.attrs["source"] = name
    return df
