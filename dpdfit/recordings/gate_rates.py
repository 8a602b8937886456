"""``gate_rates.csv``: the calibrated gate rate of each setting, read by one set of rules.

The campaign folder, the budget (``dpdfit budget --gate-rates``), ``dpdfit fidelity
--gate-rates`` and the pipeline read gate rates through :func:`read_gate_rates`.
"""

from __future__ import annotations

import os

import numpy as np
import pandas as pd

from dpdfit.errors import InputError

from .columns import CAMPAIGN_TABLES
from .tables import read_table

__all__ = ["read_gate_rates", "MIN_GATE_RATE_KHZ"]

#: a rate below this (kHz) is no gate rate: its gate time 1/xi0 overflows (e.g. 1e-320)
MIN_GATE_RATE_KHZ = 1e-6


def read_gate_rates(path: str | os.PathLike) -> pd.DataFrame:
    """``A, dpd, xi0_khz`` (+ ``xi0_err_khz``) of a gate-rate file, validated.

    A in [0, 1], dpd 0 or 1 (returned as int), ``xi0_khz`` and ``xi0_err_khz``
    > 0, no setting (A, dpd) twice, no rate below :data:`MIN_GATE_RATE_KHZ`;
    an :class:`~dpdfit.errors.InputError` names file, column and row.
    """
    name = str(path)
    required, optional = CAMPAIGN_TABLES["gate_rates"]
    df = read_table(path, list(required), list(optional),
                    ranges={"A": (0.0, 1.0), "dpd": (0, 1)},
                    positive=["xi0_khz", "xi0_err_khz"], unique=["A", "dpd"])
    v = df["dpd"].to_numpy()
    bad = v != np.round(v)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"dpd = {v[i]:g} must be 0 or 1", file=name, column="dpd", row=i + 1)
    long = df["xi0_khz"].to_numpy() < MIN_GATE_RATE_KHZ
    if long.any():
        i = int(np.flatnonzero(long)[0])
        raise InputError(f"xi0_khz = {df['xi0_khz'].iloc[i]:g} gives a gate time 1/xi0 above "
                         f"{1e3 / MIN_GATE_RATE_KHZ:g} us: not a gate rate", file=name,
                         column="xi0_khz", row=i + 1)
    df["dpd"] = df["dpd"].astype(int)
    return df
