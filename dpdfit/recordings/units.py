"""Units of imported recordings: what a stored value is in, and the campaign column's unit.

A campaign column has one documented unit (``t_us`` microseconds, ``xi0_khz``
kHz, ``phase_rad`` radians, ``A`` a fraction of full scale, ``P_dB`` dB).  A
results file stores a quantity in some unit: ndscan and ARTIQ 8 give the unit
it is *shown* in and the ``scale`` of that unit in SI, and store
``shown * scale``; :func:`stored_unit` turns that pair into the unit of the
stored number ("us" with scale 1e-6 -> "s").  A dataset written with a
``unit`` and no ``scale`` has the scale ARTIQ's own tools give it
(:func:`scale_from_metadata`): the SI factor of the unit, so a ``kHz`` dataset
without ``scale`` holds Hz.  :func:`convert` brings stored
values into the column's unit, or refuses a unit of another dimension.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["COLUMN_KINDS", "stored_unit", "convert", "UnitError", "UNITS", "ARTIQ_UNITS",
           "scale_from_metadata"]

_PREFIX = {"": 1.0, "m": 1e-3, "u": 1e-6, "µ": 1e-6, "μ": 1e-6, "n": 1e-9, "p": 1e-12,
           "k": 1e3, "M": 1e6, "G": 1e9}


def _artiq_units() -> dict:
    # Copied from ARTIQ's artiq/language/units.py (m-labs/artiq at 3740b92e, 2025;
    # last changed in 2022, when nW was added): each base unit with the prefixes
    # it registers, the smallest prefix p = 1e-12 and a factor 1000 per step of
    # "pnum_kMG" ("_" no prefix).  dpdfit does not depend on ARTIQ, so the table
    # is generated here exactly as ARTIQ generates it.
    out, prefixes = {}, "pnum_kMG"
    for unit, allowed in (("s", "pnum_"), ("Hz", "m_kMG"), ("dB", "_"), ("V", "um_k"),
                          ("A", "um_"), ("W", "num_")):
        for i, p in enumerate(prefixes):
            if p in allowed:
                out[unit if p == "_" else p + unit] = 10.0 ** (3 * i - 12)
    return out


#: ARTIQ's units (``artiq.language.units``): name -> SI factor, e.g. ``"kHz": 1e3``
ARTIQ_UNITS = _artiq_units()


def scale_from_metadata(attrs) -> float:
    """The scale of a dataset from its metadata, by ARTIQ's own rule
    (``artiq/tools.py: scale_from_metadata``): ``scale`` when given, else the SI
    factor of ``unit`` in ARTIQ's units (1 for a unit ARTIQ does not define).

    Parameters
    ----------
    attrs : mapping
        The dataset's metadata (HDF5 attributes ``unit``, ``scale``, ...).

    Returns
    -------
    float
        The factor such that the value shown in ``unit`` is ``stored / scale``.
    """
    unit = attrs.get("unit", "")
    unit = unit.decode() if isinstance(unit, bytes) else str(unit or "")
    return float(attrs["scale"]) if "scale" in attrs else ARTIQ_UNITS.get(unit, 1.0)


#: kind -> {unit: size of the unit in the kind's reference unit}
UNITS = {
    "time": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "μs": 1e-6, "ns": 1e-9},
    "frequency": {"Hz": 1.0, "kHz": 1e3, "MHz": 1e6, "GHz": 1e9},
    "angle": {"rad": 1.0, "mrad": 1e-3, "deg": math.pi / 180, "turn": 2 * math.pi,
              "turns": 2 * math.pi, "cycle": 2 * math.pi, "cycles": 2 * math.pi},
    "fraction": {"": 1.0, "1": 1.0, "fraction": 1.0, "%": 1e-2},
    "dB": {"": 1.0, "dB": 1.0},
    "number": {"": 1.0},
}

#: campaign column -> (kind, the column's unit)
COLUMN_KINDS = {
    "A": ("fraction", ""), "t_us": ("time", "us"), "xi0_khz": ("frequency", "kHz"),
    "xi0_err_khz": ("frequency", "kHz"), "phase_rad": ("angle", "rad"),
    "phase_err": ("angle", "rad"), "P_dB": ("dB", "dB"), "snr_db": ("dB", "dB"),
    "dpd": ("number", ""), "n": ("number", ""), "scan": ("number", ""), "repeat": ("number", ""),
    "valid": ("number", ""), "shots": ("number", ""), "n_even": ("number", ""),
    "n00": ("number", ""), "n01_10": ("number", ""), "n11": ("number", ""),
    # the photodiode signal is in the lab's own (arbitrary) unit: taken as stored
    "power": ("any", ""), "power_err": ("any", ""),
    "run": ("label", ""), "timestamp": ("label", ""), "sideband": ("label", ""),
    "prepared": ("label", ""),
    "sequence": ("label", ""), "wait_us": ("time", "us"),
    "power_attenuated": ("any", ""), "attenuation_db": ("dB", "dB"),
    "n_bright": ("number", ""),
}


class UnitError(ValueError):
    """A unit that does not convert to the column's (message says which and why)."""


def stored_unit(unit: str | None, scale: float | None) -> str | None:
    """The unit of a stored number, from the unit it is shown in and that unit's scale.

    ``("us", 1e-6) -> "s"``, ``("kHz", 1e3) -> "Hz"``, ``("deg", 1) -> "deg"``;
    None when the pair does not say (a scale that is no SI prefix of the unit).
    """
    unit = (unit or "").strip()
    scale = 1.0 if scale is None else float(scale)
    if scale == 1.0:
        return unit
    for p, f in _PREFIX.items():
        if p and unit.startswith(p) and len(unit) > len(p) and math.isclose(scale, f,
                                                                           rel_tol=1e-9):
            return unit[len(p):]
    return None


def convert(values, unit: str, column: str, *, full_scale_dbm: float | None = None):
    """``values`` stored in ``unit`` expressed in ``column``'s documented unit.

    From a base unit the values are divided by the column unit's size (``stored /
    scale``, ndscan's own rule, exact for a value stored as ``shown * scale``); by a
    whole number where the ratio is one (``%``); else multiplied by the ratio.  ``A`` in ``dBm`` needs ``full_scale_dbm`` (A = 10^((P - full scale)/20)).
    """
    kind, target = COLUMN_KINDS[column]
    unit = (unit or "").strip()
    if kind in ("any", "label"):
        return values
    v = np.asarray(values, dtype=float)
    if kind == "fraction" and unit in ("dBm", "dBFS"):
        if unit == "dBm" and full_scale_dbm is None:
            raise UnitError("unit 'dBm' needs full_scale_dbm (the power at A = 1)")
        ref = 0.0 if unit == "dBFS" else float(full_scale_dbm)
        return 10.0 ** ((v - ref) / 20.0)
    table = UNITS[kind]
    if unit not in table:
        raise UnitError(f"unit '{unit}' does not convert to {column}'s unit "
                        f"'{target or 'dimensionless'}' (known: "
                        f"{', '.join(repr(u) for u in table)})")
    f_from, f_to = table[unit], table[target]
    if f_from == f_to:
        return v
    if f_from == 1.0:                 # ndscan's rule: shown = stored / scale
        return v / f_to
    inv = f_to / f_from
    if inv > 1 and abs(inv - round(inv)) < 1e-9 * inv:
        return v / round(inv)         # "%" -> fraction: v / 100 is exact where v * 0.01 is not
    return v * (f_from / f_to)
