"""The confidence level of the count fits' intervals: its 1-sigma default, its normal
quantile, its check."""

from __future__ import annotations

import functools
import math

from scipy import stats

from dpdfit.errors import InputError

__all__ = ["LEVEL_1SIGMA", "normal_quantile", "check_level"]

#: Probability content of +/- 1 sigma of a normal distribution.
LEVEL_1SIGMA = math.erf(1 / math.sqrt(2))      # 0.6826894921370859


@functools.lru_cache(maxsize=64)
def normal_quantile(level: float) -> float:
    """Two-sided normal quantile: ``level = P(|Z| <= z)``."""
    return float(stats.norm.ppf(0.5 + level / 2))


def check_level(level) -> float:
    """``level`` as a float, or InputError when it is not in (0, 1)."""
    level = float(level)
    if not 0 < level < 1:
        raise InputError(f"level {level:g} must be in (0, 1)")
    return level
