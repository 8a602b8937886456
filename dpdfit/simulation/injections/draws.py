"""The harness's uniform draws of an injection's strengths."""

from __future__ import annotations

import numpy as np

__all__ = ["draw_uniform"]


def draw_uniform(rng: np.random.Generator, ranges: dict, v: dict) -> dict:
    """``v`` with each parameter of ``ranges`` (``{param: (lo, hi, signed)}``) drawn
    uniform in ``[lo, hi]``, times a random sign when signed (in the order of
    ``ranges``: the stream the harness has always drawn from)."""
    for name, (lo, hi, signed) in ranges.items():
        x = float(rng.uniform(lo, hi))
        v[name] = x * (float(rng.choice([-1.0, 1.0])) if signed else 1.0)
    return v
