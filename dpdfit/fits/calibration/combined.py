"""Amplitude and phase calibration together: the content of ``calibration.json``.

:class:`Calibration` holds an :class:`~dpdfit.fits.calibration.AmplitudeCalibration`
and an optional :class:`~dpdfit.fits.calibration.PhaseCalibration`, writes
the JSON (:meth:`Calibration.to_dict`) and reads it back
(:meth:`Calibration.from_dict`, :func:`load_calibration`).
"""

from __future__ import annotations

import datetime as _dt
import os
from dataclasses import dataclass, field

from dpdfit.core.display import Displayable
from dpdfit.core.version import __version__
from dpdfit.errors import InputError
from dpdfit.fits.calibration.amplitude import AmplitudeCalibration
from dpdfit.fits.calibration.phase import PhaseCalibration
from dpdfit.recordings.input_files import read_input_json
from dpdfit.recordings.tables import require_file

__all__ = ["Calibration", "load_calibration", "check_calibration_dict", "MAX_POWER"]

#: Arrays of ``calibration.json`` that must be present and finite, per section.
#: highest polynomial power a calibration file may hold
MAX_POWER = 40
_FINITE_KEYS = {"amplitude": ("coefficients", "covariance", "raw_coefficients", "raw_covariance"),
                "phase": ("coefficients", "covariance")}


@dataclass(frozen=True, repr=False)
class Calibration(Displayable):
    """Amplitude and (optional) phase calibration: the content of calibration.json."""

    amplitude: AmplitudeCalibration
    phase: PhaseCalibration | None = None
    created: str = field(default_factory=lambda: _dt.datetime.now(_dt.timezone.utc)
                         .isoformat(timespec="seconds"))
    #: The ``calibration.json`` it was read from (:func:`load_calibration`), for messages;
    #: not written by :meth:`to_dict`.
    file: str | None = field(default=None, compare=False)

    @property
    def A_corr(self) -> float:
        """``y(1)``, the largest correctable amplitude (normalised), of the amplitude
        calibration."""
        return self.amplitude.A_corr

    def _display_rows(self) -> list[tuple]:
        return ([("amplitude." + r[0],) + r[1:] for r in self.amplitude._display_rows()]
                + ([] if self.phase is None else
                   [("phase." + r[0],) + r[1:] for r in self.phase._display_rows()]))

    def _display_diagnostics(self) -> dict:
        diag = self.amplitude._display_diagnostics()
        if self.phase is not None:
            ph = self.phase._display_diagnostics()
            diag["warnings"] = diag["warnings"] + [f"phase: {w}" for w in ph["warnings"]]
        return diag

    def to_dict(self) -> dict:
        return {
            "dpdfit_version": __version__,
            "created": self.created,
            "amplitude": self.amplitude.to_dict(),
            "A_corr": self.amplitude.A_corr,
            "A_corr_stderr": self.amplitude.A_corr_stderr,
            "phase": None if self.phase is None else self.phase.to_dict(),
            "phi_at_1": None if self.phase is None else self.phase.phi_at_1,
            "phi_at_1_stderr": None if self.phase is None else self.phase.phi_at_1_stderr,
        }

    @classmethod
    def from_dict(cls, d: dict, file: str | None = None) -> "Calibration":
        """The calibration from the content of a ``calibration.json`` (``file``: its
        name, for messages); not validated, :func:`load_calibration` checks a file first."""
        amp = AmplitudeCalibration.from_dict(d["amplitude"])
        ph = PhaseCalibration.from_dict(d["phase"]) if d.get("phase") else None
        return cls(amplitude=amp, phase=ph, created=d.get("created", ""), file=file)

    def report(self) -> str:
        parts = [self.amplitude.report()]
        if self.phase is not None:
            parts.append(self.phase.report())
        return "\n".join(parts)


def load_calibration(path: str | os.PathLike) -> Calibration:
    """Read a ``calibration.json`` written by ``dpdfit calibrate`` (through
    :func:`~dpdfit.recordings.input_files.read_input_json`)."""
    name = require_file(path)
    # a regular file, bounded in size and depth: a FIFO or a device is refused unread
    d = read_input_json(path, what="calibration file", not_json="not valid JSON")
    check_calibration_dict(d, name)
    try:
        return Calibration.from_dict(d, file=name)
    except (KeyError, TypeError, ValueError, OverflowError) as exc:
        raise InputError(f"not a dpdfit calibration file (missing or bad key: {exc})",
                         file=name) from None


def _finite_array(value, key: str, name: str):
    import numpy as np
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"key '{key}': not an array of numbers", file=name) from None
    if arr.size == 0 or not np.all(np.isfinite(arr)):
        raise InputError(f"key '{key}': must be a non-empty array of finite numbers",
                         file=name)
    return arr


def _check_representable(coef, max_power: int, key: str, name: str) -> None:
    """The polynomial, its derivative and its square must be finite on [0, 1] (no overflow)."""
    import numpy as np
    with np.errstate(over="ignore"):
        bound = (np.abs(coef).sum() * max_power) ** 2
    if not np.isfinite(bound):
        raise InputError(f"key '{key}': values too large (the polynomial overflows on [0, 1])",
                         file=name)


def _powers(value, key: str, name: str) -> list:
    """The polynomial's powers: distinct integers 1..MAX_POWER (InputError otherwise)."""
    ok = isinstance(value, list) and all(
        isinstance(p, int) and not isinstance(p, bool) and 1 <= p <= MAX_POWER for p in value)
    if not ok or len(set(value)) != len(value):
        raise InputError(f"key '{key}': must be a list of distinct integers 1..{MAX_POWER}",
                         file=name)
    return value


def check_calibration_dict(d, name: str) -> None:
    """Raise :class:`InputError` unless the fitted arrays of ``d`` are finite and consistent.

    Checks ``amplitude`` (and ``phase`` if present): coefficients and covariance
    finite, one coefficient per power, a square covariance of that size.
    """
    if not isinstance(d, dict) or not isinstance(d.get("amplitude"), dict):
        raise InputError("not a dpdfit calibration file (missing or bad key: 'amplitude')",
                         file=name)
    for section, keys in _FINITE_KEYS.items():
        sec = d.get(section)
        if section == "phase" and not sec:
            continue
        if not isinstance(sec, dict):
            raise InputError(f"key '{section}': not an object", file=name)
        powers = _powers(sec.get("powers"), f"{section}.powers", name)
        n = len(powers)
        for key in keys:
            if key not in sec and key.startswith("raw_"):
                continue
            if key not in sec:
                raise InputError(f"key '{section}.{key}': missing", file=name)
            arr = _finite_array(sec[key], f"{section}.{key}", name)
            shape = (n, n) if "covariance" in key else (n,)
            if arr.shape != shape:
                raise InputError(f"key '{section}.{key}': shape {arr.shape}, expected {shape} "
                                 f"for {n} powers", file=name)
            if key == "coefficients":
                _check_representable(arr, max(powers), f"{section}.{key}", name)
