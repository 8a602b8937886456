"""Helpers shared by the count fits: the 1-sigma level, normal quantiles, result plumbing."""

from __future__ import annotations

import functools
import math
from dataclasses import fields

import numpy as np
from scipy import stats

from dpdfit.core.jsonable import to_jsonable
from dpdfit.errors import InputError

__all__ = ["LEVEL_1SIGMA"]

#: Probability content of +/- 1 sigma of a normal distribution.
LEVEL_1SIGMA = math.erf(1 / math.sqrt(2))      # 0.6826894921370859


def _readonly(a):
    if a is None:
        return None
    arr = np.array(a, dtype=float, copy=True)
    arr.setflags(write=False)
    return arr


def _to_dict(obj) -> dict:
    out = {}
    for f in fields(obj):
        if f.name.startswith("_"):
            continue
        out[f.name] = to_jsonable(getattr(obj, f.name), finite_only=False)
    return out


@functools.lru_cache(maxsize=64)
def _z(level: float) -> float:
    """Two-sided normal quantile: level = P(|Z| <= z)."""
    return float(stats.norm.ppf(0.5 + level / 2))


def _check_level(level) -> float:
    level = float(level)
    if not 0 < level < 1:
        raise InputError(f"level {level:g} must be in (0, 1)")
    return level
