"""Configuration of the error budget: defaults (the paper's inputs), validation, reading.

Configuration (TOML; every key optional, defaults = the paper's values)
-----------------------------------------------------------------------
::

    [state_preparation]
    rabi_amplitude = 0.997        # Rabi-flop amplitude per ion (dimensionless, 0..1]
    rabi_amplitude_err = 0.003    # its 1-sigma error (dimensionless)

    [dephasing]
    T2_ms = 50.0                  # coherence time T2 [ms]
    T2_err_ms = 5.0               # its 1-sigma error [ms]
    coefficient = 0.591           # dF/(T/T2) of the measured fidelity (dimensionless)

    [heating]
    rate_per_ms = 0.01            # heating rate (or its upper limit) [quanta/ms]
    rate_err_per_ms = 0.0         # 1-sigma error [quanta/ms], used if upper_limit = false
    upper_limit = true            # rate_per_ms is an upper limit: uniform prior [0, limit]

    [detection]
    error_per_ion = 1e-4          # per-ion bright/dark misassignment (or its upper limit)
    error_err = 0.0               # 1-sigma error, used if upper_limit = false
    upper_limit = true            # uniform prior [0, error_per_ion]

    [gate]
    time_min_us = 150.0           # shortest gate time T_g [us]
    time_max_us = 310.0           # longest gate time T_g [us]
    rates_khz = []                # optional list of gate rates xi0 [kHz]; T_g = 1/xi0
                                  # (overrides time_min_us/time_max_us)

    [delta]
    value = -0.018                # fitted fidelity offset delta (dimensionless)
    error = 0.003                 # its 1-sigma error
    enabled = true                # false: no delta, no 'unexplained'

    [monte_carlo]
    samples = 200000              # number of draws
    seed = 20240601               # numpy Generator seed
"""

from __future__ import annotations

import copy
import math
import sys
import tomllib
from pathlib import Path

from dpdfit.errors import InputError
from dpdfit.recordings.gate_rates import MIN_GATE_RATE_KHZ
from dpdfit.recordings.gate_rates import read_gate_rates
from dpdfit.recordings.input_files import read_input_bytes

from .losses import DEPHASING_COEFFICIENT

__all__ = ["DEFAULT_CONFIG", "validate_budget_config", "load_budget_config", "gate_rates_khz",
           "MIN_GATE_RATE_KHZ"]


# The paper's Table S2 inputs, kept as the paper states them; they are not the lab's
# error model (dpdfit.core.defaults.ERROR_MODEL) on purpose.  Where both hold a value
# they agree (T2 50 ms; rabi_amplitude 0.997 = 1 - p_prep 0.003) except where the paper
# gives only a bound: the budget draws heating and detection uniformly in [0, bound]
# (rate_per_ms 0.01 quanta/ms, error_per_ion 1e-4), while the error model, which needs
# one value to simulate and to predict with, takes the middle of that range
# (heating_quanta_per_s 5 /s = 0.005 quanta/ms, p_det 5e-5).  The Monte-Carlo seed is
# the budget's own stream, unrelated to the campaign seed (ERROR_MODEL.seed).
DEFAULT_CONFIG = {
    "state_preparation": {"rabi_amplitude": 0.997, "rabi_amplitude_err": 0.003},
    "dephasing": {"T2_ms": 50.0, "T2_err_ms": 5.0, "coefficient": DEPHASING_COEFFICIENT},
    "heating": {"rate_per_ms": 0.01, "rate_err_per_ms": 0.0, "upper_limit": True},
    "detection": {"error_per_ion": 1e-4, "error_err": 0.0, "upper_limit": True},
    "gate": {"time_min_us": 150.0, "time_max_us": 310.0, "rates_khz": []},
    "delta": {"value": -0.018, "error": 0.003, "enabled": True},
    "monte_carlo": {"samples": 200000, "seed": 20240601},
}

_SIGNED = {("delta", "value")}          # the only key allowed to be negative
_POSITIVE = {("dephasing", "T2_ms"), ("gate", "time_min_us"), ("gate", "time_max_us")}


def _type_name(v):
    return type(v).__name__


def _checked_value(sec: str, key: str, val):
    """``val`` for ``[sec] key`` checked against the type of its default (InputError if bad)."""
    name = f"{sec}.{key}"
    default = DEFAULT_CONFIG[sec][key]
    if isinstance(default, bool):
        if not isinstance(val, bool):
            raise InputError(f"budget config key '{name}' must be true/false, got {val!r}")
    elif isinstance(default, list):
        if not isinstance(val, list) or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) for v in val):
            raise InputError(f"budget config key '{name}' must be a list of numbers, "
                             f"got {val!r}")
        if not all(math.isfinite(v) and v > 0 for v in val):
            raise InputError(f"budget config key '{name}' must hold positive values, "
                             f"got {val!r}")
        val = [float(v) for v in val]
    elif isinstance(default, int):
        if not isinstance(val, int) or isinstance(val, bool):
            raise InputError(f"budget config key '{name}' must be an integer, got {val!r}")
        if val < (1000 if key == "samples" else 0):
            raise InputError(f"budget config key '{name}' must be "
                             f">= {1000 if key == 'samples' else 0}, got {val}")
    else:
        if not isinstance(val, (int, float)) or isinstance(val, bool):
            raise InputError(f"budget config key '{name}' must be a number, got {val!r}")
        val = float(val)
        if not math.isfinite(val):
            raise InputError(f"budget config key '{name}' must be finite, got {val}")
        if (sec, key) not in _SIGNED and val < 0:
            raise InputError(f"budget config key '{name}' must be >= 0, got {val}")
        if (sec, key) in _POSITIVE and val <= 0:
            raise InputError(f"budget config key '{name}' must be > 0, got {val}")
    return val


def _check_consistency(cfg: dict) -> None:
    """Bounds that involve the physics or two keys at once."""
    if cfg["state_preparation"]["rabi_amplitude"] > 1:
        raise InputError("budget config key 'state_preparation.rabi_amplitude' must be <= 1, "
                         f"got {cfg['state_preparation']['rabi_amplitude']}")
    if cfg["detection"]["error_per_ion"] > 0.5:
        raise InputError("budget config key 'detection.error_per_ion' must be <= 0.5, "
                         f"got {cfg['detection']['error_per_ion']}")
    g = cfg["gate"]
    if not g["rates_khz"] and g["time_min_us"] > g["time_max_us"]:
        raise InputError("budget config key 'gate.time_min_us' must be <= 'gate.time_max_us', "
                         f"got {g['time_min_us']} > {g['time_max_us']}")


def validate_budget_config(config: dict | None) -> dict:
    """Full config (defaults filled in, a fresh copy) or InputError naming the offending key.

    ``None`` gives the defaults (the paper's inputs).
    """
    cfg = copy.deepcopy(DEFAULT_CONFIG)
    if config is None:
        return cfg
    if not isinstance(config, dict):
        raise InputError(f"budget config must be a table/dict, got {_type_name(config)}")
    for sec, body in config.items():
        if sec not in DEFAULT_CONFIG:
            raise InputError(f"unknown budget config key '{sec}' "
                             f"(known sections: {', '.join(DEFAULT_CONFIG)})")
        if not isinstance(body, dict):
            raise InputError(f"budget config key '{sec}' must be a table, got {_type_name(body)}")
        for key, val in body.items():
            if key not in DEFAULT_CONFIG[sec]:
                raise InputError(f"unknown budget config key '{sec}.{key}' "
                                 f"(known: {', '.join(DEFAULT_CONFIG[sec])})")
            cfg[sec][key] = _checked_value(sec, key, val)
    _check_consistency(cfg)
    return cfg


def load_budget_config(path, *, within=None) -> dict:
    """Read and validate a budget TOML file (through
    :func:`~dpdfit.recordings.input_files.read_input_bytes`: a regular file, inside the
    folder ``within`` when given, size bounded); returns the full config (defaults
    filled in)."""
    path = Path(path)
    data = read_input_bytes(path, within=within, what="file")
    try:
        raw = tomllib.loads(data.decode("utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"invalid TOML: {exc}", file=str(path)) from None
    except UnicodeDecodeError:
        raise InputError("not a text (UTF-8 TOML) file", file=str(path)) from None
    except RecursionError:
        raise InputError("invalid TOML: arrays or tables nested too deeply to read",
                         file=str(path)) from None
    except ValueError:
        # tomllib converts an integer with int(), which refuses more digits than this
        raise InputError(f"invalid TOML: an integer of more than "
                         f"{sys.get_int_max_str_digits()} digits", file=str(path)) from None
    try:
        return validate_budget_config(raw)
    except InputError as exc:
        raise InputError(str(exc), file=str(path)) from None


def gate_rates_khz(path) -> list[float]:
    """Gate rates ``xi0`` [kHz] of a gate-rate file (``A, dpd, xi0_khz``), read by the one
    reader of such files (:func:`dpdfit.recordings.gate_rates.read_gate_rates`: A in
    [0, 1], dpd 0/1, xi0_khz > 0, repeated calibrations of a setting pooled into one rate;
    InputError names file, column, row)."""
    return [float(x) for x in read_gate_rates(path)["xi0_khz"]]
